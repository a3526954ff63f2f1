// auto's portfolio chooser on a real GP: every member plans, the plan that would
// remove the most posterior variance over the reference set wins.
#include "server/plan/member_portfolio.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "server/gp/dynamics_model.h"
#include "server/plan/plan_slots.h"
#include "server/plan/planner.h"
#include "server/plan/reference_set.h"
#include "server/plan/rollout.h"
#include "tests/plan/pendulum_gp.h"

namespace excite::plan {
namespace {

using testing::FittedModel;

PlanOptions PortfolioOptions() {
  PlanOptions o;
  o.strategy = Strategy::kAuto;
  o.auto_chooser = AutoChooser::kPortfolio;
  o.horizon = 5;
  o.max_iterations = 30;
  o.restarts = 0;
  o.seed = 3;
  o.input_lower = Eigen::VectorXd::Constant(1, -3.0);
  o.input_upper = Eigen::VectorXd::Constant(1, 3.0);
  o.state_lower = Eigen::Vector2d(-3.0, -8.0);
  o.state_upper = Eigen::Vector2d(3.0, 8.0);
  o.roi_reference_points = 40;
  return o;
}

// The share of the summed variance over `reference` that observing the rollout's
// points removes, by a second route: the model with those points added as data
// (the same fit, made again: AddSamples keeps its hyperparameters and appends to
// the Cholesky factor), its variance over the reference set against today's.
double VarianceRemovedByAddingThePoints(const gp::DynamicsModel& model, int samples,
                                        const Rollout& rollout,
                                        const Eigen::MatrixXd& reference) {
  Eigen::MatrixXd before, after, mean;
  model.Predict(reference, &mean, &before, nullptr, nullptr);
  gp::DynamicsModel more = FittedModel(samples);
  // The targets do not change a GP's variance.
  EXPECT_TRUE(more.AddSamples(rollout.states, rollout.inputs, rollout.means).ok());
  more.Predict(reference, &mean, &after, nullptr, nullptr);
  return (before - after).sum() / before.sum();
}

TEST(PortfolioTest, ChoosesTheMemberPlanThatRemovesTheMostVariance) {
  const gp::DynamicsModel model = FittedModel(60);
  PlanOptions options = PortfolioOptions();
  Eigen::MatrixXd reference;
  auto criterion = PortfolioCriterion::Create(model, options, &reference);
  ASSERT_TRUE(criterion.ok()) << criterion.status();
  ASSERT_EQ(reference.rows(), 40);
  Eigen::VectorXd z_lower(3), z_upper(3);
  z_lower << options.state_lower, options.input_lower;
  z_upper << options.state_upper, options.input_upper;
  EXPECT_EQ(reference, HaltonReferenceSet(z_lower, z_upper, 40, options.seed));

  // The default members and random, whose plans the criterion can tell apart.
  EXPECT_EQ(options.AutoMembers(),
            (std::vector<Strategy>{Strategy::kRec, Strategy::kMi}));
  options.auto_members = {Strategy::kRec, Strategy::kMi, Strategy::kRandom};
  const std::vector<Strategy> members = options.AutoMembers();
  for (const Eigen::Vector2d& x0 : {Eigen::Vector2d(0.2, -0.5), Eigen::Vector2d(2.0, 3.0),
                                    Eigen::Vector2d(-1.0, 6.0)}) {
    Planner portfolio(options);  // a first call: no member has a warm start
    PlanSummary summary;
    const auto chosen = portfolio.PlanInputs(model, x0, 0, PlanLimits{}, &summary);
    ASSERT_TRUE(chosen.ok()) << chosen.status();
    EXPECT_EQ(chosen->apply_count, 1);
    EXPECT_EQ(chosen->states.rows(), chosen->inputs.rows());
    // Each member alone, from the same state, scored by the second route.
    std::vector<double> removed;
    int chosen_index = -1;
    for (size_t k = 0; k < members.size(); ++k) {
      PlanOptions own = options;
      own.strategy = members[k];
      own.auto_members.clear();
      Planner alone(own);
      PlanSummary ignored;
      const auto plan = alone.PlanInputs(model, x0, 0, PlanLimits{}, &ignored);
      ASSERT_TRUE(plan.ok()) << plan.status();
      const Rollout rollout = RollOut(model, x0, plan->inputs);
      ASSERT_TRUE(rollout.valid);
      removed.push_back(VarianceRemovedByAddingThePoints(model, 60, rollout, reference));
      EXPECT_NEAR(criterion->Score(rollout), removed.back(), 1e-9 * removed.back());
      if (members[k] == summary.planned_by) {
        chosen_index = static_cast<int>(k);
        EXPECT_EQ(chosen->inputs, plan->inputs);
      }
    }
    ASSERT_GE(chosen_index, 0);
    // The chosen plan removes the most (rec and mi may make the same plan: a tie
    // within rounding); some member's plan removes clearly less, so the choice
    // is real.
    const double most = *std::max_element(removed.begin(), removed.end());
    const double least = *std::min_element(removed.begin(), removed.end());
    EXPECT_NEAR(removed[static_cast<size_t>(chosen_index)], most, 1e-9 * most);
    EXPECT_GT(most - least, 1e-3 * most);
  }
}

// Members planning at once on helper threads (3 slots) choose the plans they
// choose one after another (1 slot), to the bit, over a session's calls.
TEST(PortfolioTest, MembersAtOnceChooseAsMembersInTurn) {
  const gp::DynamicsModel model = FittedModel(80);
  std::vector<std::vector<Eigen::MatrixXd>> runs;
  std::vector<std::vector<Strategy>> chosen_by;
  for (int slots : {1, 3}) {
    SetConcurrentPlans(slots);
    Planner planner(PortfolioOptions());
    PlanSlot slot;  // as the session's call holds one
    ASSERT_TRUE(slot.Acquire(std::nullopt, nullptr).ok());
    runs.emplace_back();
    chosen_by.emplace_back();
    Eigen::Vector2d x(0.1, 0.0);
    for (int k = 0; k < 4; ++k) {
      PlanSummary summary;
      const auto plan = planner.PlanInputs(model, x, k, PlanLimits{}, &summary);
      ASSERT_TRUE(plan.ok()) << plan.status();
      runs.back().push_back(plan->inputs);
      chosen_by.back().push_back(summary.planned_by);
      x = plan->states.row(0).transpose() + Eigen::Vector2d(0.3, -0.2);
    }
  }
  SetConcurrentPlans(1);
  EXPECT_EQ(chosen_by[0], chosen_by[1]);
  ASSERT_EQ(runs[0].size(), runs[1].size());
  for (size_t k = 0; k < runs[0].size(); ++k) EXPECT_EQ(runs[0][k], runs[1][k]) << k;
}

// Without state bounds the criterion is mi's mutual information: for one point,
// 1/2 sum_j log(1 + var_j / noise_j).
TEST(PortfolioTest, WithoutStateBoundsTheCriterionIsTheMutualInformation) {
  const gp::DynamicsModel model = FittedModel(60);
  PlanOptions options = PortfolioOptions();
  options.state_lower.resize(0);
  options.state_upper.resize(0);
  Eigen::MatrixXd reference;
  auto criterion = PortfolioCriterion::Create(model, options, &reference);
  ASSERT_TRUE(criterion.ok()) << criterion.status();
  EXPECT_EQ(reference.rows(), 0);
  const Rollout rollout =
      RollOut(model, Eigen::Vector2d(0.4, 1.0), Eigen::MatrixXd::Constant(1, 1, 1.5));
  const Eigen::VectorXd noise = model.noise_variances();
  double information = 0.0;
  for (int j = 0; j < 2; ++j) {
    information += 0.5 * std::log1p(rollout.variances(0, j) / noise(j));
  }
  EXPECT_NEAR(criterion->Score(rollout), information, 1e-10);
  Rollout broken = rollout;
  broken.valid = false;
  EXPECT_TRUE(std::isnan(criterion->Score(broken)));
}

}  // namespace
}  // namespace excite::plan
