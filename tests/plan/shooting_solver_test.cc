#include "server/plan/shooting_solver.h"

#include <gtest/gtest.h>

#include <vector>

#include "server/plan/entropy_objective.h"
#include "server/plan/rollout.h"
#include "tests/plan/analytic_predictor.h"

namespace excite::plan {
namespace {

using ::excite::plan::testing::AnalyticPendulum;

// The entropy objective plus a kink in every input, sum_i |u_i - 0.3|: its
// minimiser sits on the kinks, where the gradient jumps, so Ipopt does not converge
// and only the iteration limit or the stall rule ends a start.
class KinkedEntropyObjective final : public ShootingObjective {
 public:
  double Evaluate(const Eigen::MatrixXd& z, const Eigen::MatrixXd& mean,
                  const Eigen::MatrixXd& variance,
                  const std::vector<Eigen::MatrixXd>* mean_jacobians,
                  const std::vector<Eigen::MatrixXd>* variance_jacobians,
                  Eigen::MatrixXd* gradient) const override {
    const Eigen::ArrayXd u = z.col(2).array() - 0.3;
    const double entropy = entropy_.Evaluate(z, mean, variance, mean_jacobians,
                                             variance_jacobians, gradient);
    if (gradient != nullptr) gradient->col(2).array() += u.sign();
    return entropy + u.abs().sum();
  }

 private:
  NegativeEntropyObjective entropy_;
};

// Two starts on the analytic pendulum, M = 8.
ShootingResult SolveTwoStarts(double stall_tolerance, int max_iterations) {
  static const AnalyticPendulum model(1);
  static const KinkedEntropyObjective objective;
  const Eigen::VectorXd lower = Eigen::VectorXd::Constant(1, -2.0);
  const Eigen::VectorXd upper = Eigen::VectorXd::Constant(1, 2.0);
  Eigen::MatrixXd ramp(8, 1);
  for (int i = 0; i < 8; ++i) ramp(i, 0) = -1.5 + 0.4 * i;
  std::vector<Eigen::MatrixXd> starts = {Eigen::MatrixXd::Zero(8, 1), ramp};
  ShootingSettings settings;
  settings.max_iterations = max_iterations;
  settings.tolerance = 1e-14;
  settings.stall_tolerance = stall_tolerance;
  return SolveFromStarts(model, objective, Eigen::Vector2d(0.1, 0.0), lower, upper,
                         starts, settings, nullptr);
}

TEST(ShootingSolverTest, WithoutTheStallRuleEveryStartRunsToItsIterationLimit) {
  const ShootingResult result = SolveTwoStarts(0.0, 60);
  EXPECT_EQ(result.starts, 2);
  EXPECT_EQ(result.iterations, 2 * 60);
  EXPECT_EQ(result.status, PlanStatus::kIterationLimit);
}

// A relative tolerance no improvement can meet: the first check (iteration 10)
// sets the best rollout, and a start ends a window (max_iterations / 10 = 10
// iterations) later, as converged; the next start still runs.
TEST(ShootingSolverTest, AStalledStartEndsAndTheNextStartRuns) {
  const ShootingResult result = SolveTwoStarts(1e9, 100);
  EXPECT_FALSE(result.stopped);
  EXPECT_EQ(result.starts, 2);
  // Ipopt numbers its iterations from 0: the 20th poll is iteration 19.
  EXPECT_EQ(result.iterations, 2 * 19);
  EXPECT_EQ(result.status, PlanStatus::kConverged);
  ASSERT_TRUE(result.best.valid);
}

// The rollouts the rule checks are candidates too, and a real tolerance stops a
// start only where it has stopped improving: the plan is as good as the one of a
// solve without the rule, to the rule's tolerance, and costs fewer iterations.
TEST(ShootingSolverTest, StallRuleKeepsThePlanWithinItsTolerance) {
  const ShootingResult full = SolveTwoStarts(0.0, 100);
  const ShootingResult stalled = SolveTwoStarts(1e-3, 100);
  ASSERT_TRUE(full.best.valid);
  ASSERT_TRUE(stalled.best.valid);
  EXPECT_LT(stalled.iterations, full.iterations);
  EXPECT_LE(stalled.value, full.value + 1e-3 * std::max(1.0, std::abs(full.value)));
  // The plan's value is its rollout's objective.
  EXPECT_DOUBLE_EQ(stalled.value,
                   RolloutObjective(KinkedEntropyObjective(), stalled.best));
}

}  // namespace
}  // namespace excite::plan
