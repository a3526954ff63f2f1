#include "server/plan/auto_planner.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "server/plan/member_bandit.h"
#include "tests/plan/analytic_predictor.h"

namespace excite::plan {
namespace {

using ::excite::plan::testing::AnalyticPendulum;

TEST(MemberBanditTest, StartsUniformAndMatchesExp3ByHand) {
  MemberBandit bandit(4, 0.1);
  EXPECT_TRUE(bandit.Probabilities().isApprox(Eigen::Vector4d::Constant(0.25), 1e-15));
  bandit.Reward(0, 0.25, 1.0);
  // w_0 = exp(gamma r / (p K)) = exp(0.1), the others 1.
  const double w = std::exp(0.1);
  const Eigen::VectorXd p = bandit.Probabilities();
  EXPECT_NEAR(p(0), 0.9 * w / (w + 3.0) + 0.025, 1e-15);
  EXPECT_NEAR(p(1), 0.9 / (w + 3.0) + 0.025, 1e-15);
  EXPECT_NEAR(p.sum(), 1.0, 1e-15);
}

TEST(MemberBanditTest, EveryMemberKeepsItsFloor) {
  MemberBandit bandit(4, 0.1);
  for (int i = 0; i < 10000; ++i) bandit.Reward(2, bandit.Probabilities()(2), 1.0);
  const Eigen::VectorXd p = bandit.Probabilities();
  EXPECT_NEAR(p(2), 0.9 + 0.025, 1e-12);
  for (int k : {0, 1, 3}) EXPECT_NEAR(p(k), 0.025, 1e-12);
  EXPECT_TRUE(p.allFinite());
}

TEST(MemberBanditTest, DrawIsTheInverseCdf) {
  MemberBandit bandit(3, 0.3);
  bandit.Reward(1, 1.0 / 3.0, 1.0);
  const Eigen::VectorXd p = bandit.Probabilities();
  EXPECT_EQ(bandit.Draw(0.0), 0);
  EXPECT_EQ(bandit.Draw(p(0) - 1e-12), 0);
  EXPECT_EQ(bandit.Draw(p(0) + 1e-12), 1);
  EXPECT_EQ(bandit.Draw(p(0) + p(1) + 1e-12), 2);
  EXPECT_EQ(bandit.Draw(1.0 - 1e-17), 2);
}

TEST(MemberBanditTest, RewardsOutsideTheUnitIntervalAreClamped) {
  MemberBandit a(2, 0.2), b(2, 0.2);
  a.Reward(0, 0.5, 7.0);
  b.Reward(0, 0.5, 1.0);
  EXPECT_TRUE(a.Probabilities().isApprox(b.Probabilities(), 1e-15));
  a.Reward(1, 0.5, std::nan(""));  // no weight change
  EXPECT_TRUE(a.Probabilities().isApprox(b.Probabilities(), 1e-15));
}

TEST(SurpriseScaleTest, RewardsAreScaleFreeAndFollowTheClosedForm) {
  SurpriseScale small, large;
  const std::vector<Eigen::Vector2d> errors = {{0.1, 0.02}, {0.3, 0.01}, {0.05, 0.04}};
  for (const Eigen::Vector2d& e : errors) {
    EXPECT_NEAR(small.Reward(e), large.Reward(1000.0 * e), 1e-12);
  }
  SurpriseScale scale;
  EXPECT_NEAR(scale.Reward(errors[0]), 0.5, 1e-15);  // q = 1: its own mean
  // Second: s = (0.1^2 + 0.3^2) / 2, (0.02^2 + 0.01^2) / 2.
  const double q = 0.5 * (0.09 / 0.05 + 0.0001 / 0.00025);
  EXPECT_NEAR(scale.Reward(errors[1]), q / (1.0 + q), 1e-12);
}

PlanOptions AutoOptions(std::vector<Strategy> members) {
  PlanOptions o;
  o.strategy = Strategy::kAuto;
  o.auto_chooser = AutoChooser::kBandit;
  o.horizon = 3;
  o.max_iterations = 10;
  o.restarts = 0;
  o.input_lower = Eigen::VectorXd::Constant(1, -1.0);
  o.input_upper = Eigen::VectorXd::Constant(1, 1.0);
  o.auto_members = std::move(members);
  return o;
}

// Runs `calls` plans, each followed by the model's prediction of the first
// transition plus `error_of(member)`, `step` samples later; `measured`: whether
// the planner is told that x is measured.
std::vector<Strategy> Explore(AutoPlanner* planner, int calls, int step,
                              double (*error_of)(Strategy), bool measured = true) {
  const AnalyticPendulum model;
  Eigen::VectorXd x = Eigen::Vector2d(0.3, 0.0);
  std::vector<Strategy> drawn;
  for (int k = 0; k < calls; ++k) {
    PlanSummary summary;
    const auto plan = planner->PlanInputs(model, x, int64_t{k} * step, PlanLimits{},
                                          measured, &summary);
    EXPECT_TRUE(plan.ok()) << plan.status();
    if (!plan.ok()) break;
    EXPECT_EQ(plan->apply_count, 1);
    // Predicted states also for the signal member (greedy plans one input).
    EXPECT_EQ(plan->states.rows(), plan->inputs.rows());
    EXPECT_EQ(plan->variances.rows(), plan->inputs.rows());
    drawn.push_back(summary.planned_by);
    Eigen::MatrixXd z(1, 3), mean;
    z << x.transpose(), plan->inputs.row(0);
    model.Predict(z, &mean, nullptr, nullptr, nullptr);
    x = mean.row(0).transpose();
    x(0) += error_of(summary.planned_by);
  }
  return drawn;
}

double RandomSurprises(Strategy member) {
  return member == Strategy::kRandom ? 0.5 : 1e-3;
}

TEST(AutoPlannerTest, TheMemberWhoseTransitionsSurpriseTheModelIsDrawnMore) {
  AutoPlanner planner(AutoOptions({Strategy::kRec, Strategy::kRandom}));
  const std::vector<Strategy> drawn = Explore(&planner, 120, 1, &RandomSurprises);
  const Eigen::VectorXd p = planner.Probabilities();
  EXPECT_GT(p(1), 0.8) << p.transpose();
  EXPECT_GE(p(0), 0.05 - 1e-12);  // rec keeps gamma / K
  int random = 0;
  for (Strategy s : drawn) random += s == Strategy::kRandom;
  EXPECT_GT(random, 70);
}

TEST(AutoPlannerTest, NoRewardWhenTheClientDidNotApplyExactlyOneInput) {
  AutoPlanner planner(AutoOptions({Strategy::kRec, Strategy::kRandom}));
  Explore(&planner, 20, 2, &RandomSurprises);  // two samples between calls
  EXPECT_TRUE(planner.Probabilities().isApprox(Eigen::Vector2d(0.5, 0.5), 1e-15));
}

// A state predicted after pending inputs is no plant's answer to any input.
TEST(AutoPlannerTest, NoRewardWhenTheStateIsPredicted) {
  AutoPlanner planner(AutoOptions({Strategy::kRec, Strategy::kRandom}));
  Explore(&planner, 20, 1, &RandomSurprises, /*measured=*/false);
  EXPECT_TRUE(planner.Probabilities().isApprox(Eigen::Vector2d(0.5, 0.5), 1e-15));
}

TEST(AutoPlannerTest, TheSameSeedDrawsTheSameMembers) {
  AutoPlanner a(AutoOptions({Strategy::kRec, Strategy::kGreedy, Strategy::kRandom}));
  AutoPlanner b(AutoOptions({Strategy::kRec, Strategy::kGreedy, Strategy::kRandom}));
  EXPECT_EQ(Explore(&a, 15, 1, &RandomSurprises), Explore(&b, 15, 1, &RandomSurprises));
}

TEST(AutoPlannerTest, TheBanditsDefaultMembersNeedStateBoundsForRoi) {
  PlanOptions o = AutoOptions({});
  EXPECT_EQ(
      AutoPlanner(o).members(),
      (std::vector<Strategy>{Strategy::kRec, Strategy::kOptimistic, Strategy::kRandom}));
  o.state_lower = Eigen::Vector2d(-3.0, -8.0);
  o.state_upper = Eigen::Vector2d(3.0, 8.0);
  EXPECT_EQ(AutoPlanner(o).members(),
            (std::vector<Strategy>{Strategy::kRec, Strategy::kOptimistic, Strategy::kRoi,
                                   Strategy::kRandom}));
}

TEST(AutoPlannerTest, OptionsRefuseMembersThatCannotBeMembers) {
  for (Strategy bad : {Strategy::kPa, Strategy::kSep, Strategy::kAuto}) {
    const absl::Status s = AutoOptions({Strategy::kRec, bad}).Validate(2, 1);
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << InfoOf(bad).name;
    EXPECT_NE(s.message().find("cannot be a member of auto"), std::string::npos) << s;
  }
  const absl::Status twice = AutoOptions({Strategy::kRec, Strategy::kRec}).Validate(2, 1);
  EXPECT_NE(twice.message().find("named twice"), std::string::npos) << twice;
  // roi without state bounds: its own need, named as auto's member's.
  const absl::Status roi = AutoOptions({Strategy::kRoi}).Validate(2, 1);
  EXPECT_NE(roi.message().find("auto's member roi: roi needs state bounds"),
            std::string::npos)
      << roi;
  EXPECT_TRUE(AutoOptions({Strategy::kRec, Strategy::kRandom}).Validate(2, 1).ok());
}

}  // namespace
}  // namespace excite::plan
