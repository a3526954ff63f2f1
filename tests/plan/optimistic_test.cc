// Optimistic exploration (OPAX) on the real GP: the objective against a closed
// form and central differences, the hallucinated rollout against its definition,
// the NLP's optimistic dynamics rows under Ipopt's derivative checker, and plans
// whose states follow the optimistic dynamics within beta standard deviations.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "server/gp/dynamics_model.h"
#include "server/plan/multiple_shooting_nlp.h"
#include "server/plan/optimistic_objective.h"
#include "server/plan/planner.h"
#include "server/plan/rollout.h"
#include "tests/plan/pendulum_gp.h"

namespace excite::plan {
namespace {

using testing::CheckerStart;
using testing::DerivativeCheckerLog;
using testing::FittedModel;

Eigen::MatrixXd Points() {
  Eigen::MatrixXd z(4, 3);
  z << 0.2, -0.5, 1.0,  //
      -1.0, 2.0, -2.5,  //
      2.5, 6.0, 0.3,    //
      0.0, 0.0, 0.0;
  return z;
}

TEST(OptimisticObjectiveTest, ClosedFormAndCentralDifferences) {
  const gp::DynamicsModel model = FittedModel(80);
  const Eigen::VectorXd noise = model.ObservationNoiseVariances();
  auto objective = NegativeLogVarianceRatioObjective::Create(noise);
  ASSERT_TRUE(objective.ok()) << objective.status();
  const auto value_at = [&](const Eigen::MatrixXd& z) {
    Eigen::MatrixXd mean, variance;
    model.Predict(z, &mean, &variance, nullptr, nullptr);
    return objective->Evaluate(z, mean, variance, nullptr, nullptr, nullptr);
  };
  const Eigen::MatrixXd z = Points();
  Eigen::MatrixXd mean, variance, gradient;
  std::vector<Eigen::MatrixXd> mean_jacobians, variance_jacobians;
  model.Predict(z, &mean, &variance, &mean_jacobians, &variance_jacobians);
  const double value = objective->Evaluate(z, mean, variance, &mean_jacobians,
                                           &variance_jacobians, &gradient);
  double expected = 0.0;
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 2; ++j) expected -= std::log(1.0 + variance(i, j) / noise(j));
  }
  EXPECT_NEAR(value, expected, 1e-12 * std::abs(expected));
  for (int i = 0; i < 4; ++i) {
    for (int l = 0; l < 3; ++l) {
      const double h = 1e-5;
      Eigen::MatrixXd zp = z, zm = z;
      zp(i, l) += h;
      zm(i, l) -= h;
      const double numeric = (value_at(zp) - value_at(zm)) / (2 * h);
      EXPECT_NEAR(gradient(i, l), numeric, 1e-6 * std::max(1.0, std::abs(numeric)))
          << "point " << i << " dimension " << l;
    }
  }
  EXPECT_FALSE(NegativeLogVarianceRatioObjective::Create(Eigen::Vector2d(0.1, 0.0)).ok());
  EXPECT_FALSE(NegativeLogVarianceRatioObjective::Create(Eigen::VectorXd()).ok());
}

TEST(OptimisticRolloutTest, FollowsTheHallucinatedDynamics) {
  const gp::DynamicsModel model = FittedModel(60);
  const Eigen::Vector2d x0(0.3, -0.4);
  Eigen::MatrixXd inputs(3, 1);
  inputs << 1.0, -2.0, 0.5;
  Hallucination h{1.7, Eigen::MatrixXd(2, 2)};
  h.eta << 1.0, -0.5, -1.0, 0.25;
  const Rollout r = RollOut(model, x0, inputs, &h);
  ASSERT_TRUE(r.valid);
  Eigen::VectorXd x = x0;
  for (int i = 0; i < 3; ++i) {
    EXPECT_LT((r.states.row(i).transpose() - x).norm(), 1e-12) << i;
    Eigen::MatrixXd z(1, 3), mean, variance;
    z << x.transpose(), inputs(i, 0);
    model.Predict(z, &mean, &variance, nullptr, nullptr);
    EXPECT_LT((r.means.row(i) - mean.row(0)).norm(), 1e-12);
    x = mean.row(0).transpose();
    if (i < 2) {
      x += 1.7 *
           variance.row(0).transpose().cwiseSqrt().cwiseProduct(h.eta.row(i).transpose());
    }
  }
  // Without a hallucination (or with eta = 0) it is the mean rollout.
  const Rollout mean_rollout = RollOut(model, x0, inputs);
  Hallucination zero{1.7, Eigen::MatrixXd::Zero(2, 2)};
  const Rollout zero_rollout = RollOut(model, x0, inputs, &zero);
  EXPECT_LT((mean_rollout.states - zero_rollout.states).norm(), 1e-15);
  EXPECT_GT((mean_rollout.states - r.states).norm(), 1e-3);
}

TEST(OptimisticNlpTest, IpoptDerivativeCheckerWithHallucinatedControlsAndABox) {
  const gp::DynamicsModel model = FittedModel(80);
  Eigen::MatrixXd inputs, states;
  CheckerStart(&inputs, &states);
  auto objective =
      NegativeLogVarianceRatioObjective::Create(model.ObservationNoiseVariances());
  ASSERT_TRUE(objective.ok());
  Ipopt::SmartPtr<MultipleShootingNlp> nlp = new MultipleShootingNlp(
      model, *objective, Eigen::Vector2d(0.1, -0.2), Eigen::VectorXd::Constant(1, -3.0),
      Eigen::VectorXd::Constant(1, 3.0), inputs, states);
  // Non-zero hallucinated controls, so that every term of the rows is exercised.
  Eigen::MatrixXd eta(7, 2);
  for (int i = 0; i < 7; ++i) eta.row(i) << std::sin(1.3 * i), 0.8 * std::cos(0.7 * i);
  nlp->SetOptimism(1.5, eta);
  SafeBox box;
  box.lower = Eigen::Vector2d(-1.0, -3.0);
  box.upper = Eigen::Vector2d(1.0, 3.0);
  box.margin = 1.5;
  nlp->SetSafeBox(box);
  EXPECT_EQ(nlp->num_variables(), 8 + 7 * 2 + 7 * 2);
  EXPECT_EQ(nlp->num_constraints(), 7 * 2 + 2 * 8 * 2);
  const Eigen::VectorXd w = nlp->StartingPoint();
  EXPECT_LT((nlp->EtaOf(w) - eta).norm(), 1e-15);
  const std::string log = DerivativeCheckerLog(nlp);
  EXPECT_NE(log.find("No errors detected by derivative checker"), std::string::npos)
      << log;
}

// A plan's states follow the optimistic dynamics: each next state lies within
// beta one-step standard deviations of the mean, the optimism is used, and the
// reported objective is the summed log(1 + var / noise) along the plan.
TEST(OptimisticPlannerTest, PlansAlongAnOptimisticTrajectory) {
  const gp::DynamicsModel model = FittedModel(120);
  PlanOptions o;
  o.strategy = Strategy::kOptimistic;
  o.horizon = 10;
  o.optimism_beta = 2.0;
  o.input_lower = Eigen::VectorXd::Constant(1, -3.0);
  o.input_upper = Eigen::VectorXd::Constant(1, 3.0);
  Planner planner(o);
  PlanSummary summary;
  const Eigen::Vector2d x0(0.2, 0.5);
  const auto plan = planner.PlanInputs(model, x0, 0, PlanLimits{}, &summary);
  ASSERT_TRUE(plan.ok()) << plan.status();
  ASSERT_EQ(plan->inputs.rows(), 10);
  ASSERT_EQ(plan->states.rows(), 10);
  EXPECT_EQ(plan->apply_count, 1);
  EXPECT_TRUE((plan->inputs.array().abs() <= 3.0 + 1e-12).all());
  EXPECT_LT((plan->states.row(0).transpose() - x0).norm(), 1e-12);
  Eigen::MatrixXd z(10, 3), mean, variance;
  z << plan->states, plan->inputs;
  model.Predict(z, &mean, &variance, nullptr, nullptr);
  double largest_deviation = 0.0;
  for (int i = 0; i + 1 < 10; ++i) {
    for (int j = 0; j < 2; ++j) {
      const double deviation = std::abs(plan->states(i + 1, j) - mean(i, j));
      EXPECT_LE(deviation, 2.0 * std::sqrt(variance(i, j)) * (1 + 1e-9) + 1e-12);
      largest_deviation = std::max(largest_deviation, deviation);
    }
  }
  EXPECT_GT(largest_deviation, 1e-3);
  const Eigen::VectorXd noise = model.ObservationNoiseVariances();
  double expected = 0.0;
  for (int i = 0; i < 10; ++i) {
    for (int j = 0; j < 2; ++j) expected += std::log1p(variance(i, j) / noise(j));
  }
  EXPECT_NEAR(summary.objective, expected, 1e-9 * expected);
  EXPECT_LT((plan->variances - variance).norm(), 1e-9);

  o.optimism_beta = 0.0;
  Planner invalid(o);
  EXPECT_EQ(invalid.PlanInputs(model, x0, 0, PlanLimits{}, &summary).status().code(),
            absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace excite::plan
