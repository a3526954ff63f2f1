// The planner on a real gp::DynamicsModel fitted on pendulum data (the analytic
// stand-in of the other tests replaced by the GP engine).
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "server/gp/dynamics_model.h"
#include "server/plan/entropy_objective.h"
#include "server/plan/entropy_search.h"
#include "server/plan/ipopt_solve.h"
#include "server/plan/multiple_shooting_nlp.h"
#include "server/plan/plan_slots.h"
#include "server/plan/planner.h"
#include "server/plan/steering_objective.h"
#include "server/plan/strategy.h"
#include "tests/plan/pendulum_gp.h"

namespace excite::plan {
namespace {

// The paper's objective (the NLP keeps a reference: it lives as long as the test).
const NegativeEntropyObjective kEntropy;

using testing::CheckerStart;
using testing::DerivativeCheckerLog;
using testing::FittedModel;

TEST(PlannerGpTest, IpoptDerivativeCheckerOnTheGp) {
  const gp::DynamicsModel model = FittedModel(80);
  Eigen::MatrixXd inputs, states;
  CheckerStart(&inputs, &states);
  Ipopt::SmartPtr<MultipleShootingNlp> nlp = new MultipleShootingNlp(
      model, kEntropy, Eigen::Vector2d(0.1, -0.2), Eigen::VectorXd::Constant(1, -3.0),
      Eigen::VectorXd::Constant(1, 3.0), inputs, states);
  const std::string log = DerivativeCheckerLog(nlp);
  EXPECT_NE(log.find("No errors detected by derivative checker"), std::string::npos)
      << log;
}

// Plans on four threads, two at once (the plan slots of a 2-core server), whose Ipopt
// steps and model work run in parallel and whose MUMPS calls take turns, are the
// plans each makes alone, to the bit: for the strategies that solve with Ipopt along
// a trajectory (rec, pa, optimistic).
TEST(PlannerGpTest, ConcurrentPlansAreThePlansMadeAlone) {
  const gp::DynamicsModel first = FittedModel(150);
  const gp::DynamicsModel second = FittedModel(220);
  const gp::DynamicsModel* const models[] = {&first, &second};
  const double angles[] = {0.2, -0.4};
  for (const Strategy strategy : {Strategy::kRec, Strategy::kPa, Strategy::kOptimistic}) {
    PlanOptions o;
    o.strategy = strategy;
    o.input_lower = Eigen::VectorXd::Constant(1, -3.0);
    o.input_upper = Eigen::VectorXd::Constant(1, 3.0);
    const auto plan = [&o](const gp::DynamicsModel& model, double angle) {
      Planner planner(o);
      Eigen::MatrixXd inputs;
      for (int step = 0; step < 3; ++step) {  // warm-started replans
        PlanSummary summary;
        auto p = planner.PlanInputs(model, Eigen::Vector2d(angle, 0.1 * step), 0,
                                    PlanLimits{}, &summary);
        EXPECT_TRUE(p.ok()) << p.status();
        if (p.ok()) inputs = p->inputs;
      }
      return inputs;
    };
    SetConcurrentPlans(1);
    const Eigen::MatrixXd alone[] = {plan(*models[0], angles[0]),
                                     plan(*models[1], angles[1])};
    SetConcurrentPlans(2);
    Eigen::MatrixXd together[4];
    std::vector<std::thread> threads;
    for (int t = 0; t < 4; ++t) {
      threads.emplace_back([&, t] { together[t] = plan(*models[t % 2], angles[t % 2]); });
    }
    for (std::thread& t : threads) t.join();
    for (int t = 0; t < 4; ++t) {
      EXPECT_EQ(together[t], alone[t % 2]) << InfoOf(strategy).name << " thread " << t;
    }
  }
  SetConcurrentPlans(1);
}

TEST(PlannerGpTest, RecPlanBeatsRandomSequences) {
  const gp::DynamicsModel model = FittedModel(150);
  PlanOptions o;
  o.strategy = Strategy::kRec;
  o.horizon = 15;
  o.input_lower = Eigen::VectorXd::Constant(1, -3.0);
  o.input_upper = Eigen::VectorXd::Constant(1, 3.0);
  Planner planner(o);
  const Eigen::VectorXd x0 = Eigen::Vector2d(0.0, 0.0);
  PlanSummary summary;
  const auto plan = planner.PlanInputs(model, x0, 0, PlanLimits{}, &summary);
  ASSERT_TRUE(plan.ok()) << plan.status();
  ASSERT_EQ(plan->inputs.rows(), 15);
  EXPECT_TRUE(plan->inputs.allFinite());
  EXPECT_LE(plan->inputs.maxCoeff(), 3.0);
  EXPECT_GE(plan->inputs.minCoeff(), -3.0);
  EXPECT_NEAR(summary.objective, Entropy(plan->variances), 1e-9);

  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  double best_random = -1e300;
  for (int r = 0; r < 100; ++r) {
    Eigen::VectorXd x = x0;
    Eigen::MatrixXd variances(15, 2);
    for (int i = 0; i < 15; ++i) {
      Eigen::MatrixXd z(1, 3), mean, var;
      z << x.transpose(), u(rng);
      model.Predict(z, &mean, &var, nullptr, nullptr);
      variances.row(i) = var.row(0);
      x = mean.row(0).transpose();
    }
    best_random = std::max(best_random, Entropy(variances));
  }
  EXPECT_GE(summary.objective, best_random);
  RecordProperty("planned_entropy", std::to_string(summary.objective));
  RecordProperty("best_random_entropy", std::to_string(best_random));
  RecordProperty("plan_ms", std::to_string(summary.wall_time_ms));
  RecordProperty("iterations", std::to_string(summary.iterations));

  // A second (warm-started) call from the predicted next state.
  const auto second = planner.PlanInputs(model, plan->states.row(1).transpose(), 0,
                                         PlanLimits{}, &summary);
  ASSERT_TRUE(second.ok()) << second.status();
  EXPECT_EQ(second->inputs.rows(), 15);
}

// sep's search on the GP: the analytic entropy gradient against central
// differences, and the searched z* against 1000 random points of the box.
TEST(PlannerGpTest, SepSearchOnTheGp) {
  const gp::DynamicsModel model = FittedModel(150);
  const Eigen::Vector3d lower(-3.14159, -8.0, -3.0), upper(3.14159, 8.0, 3.0);
  std::mt19937_64 rng(5);
  const auto random_point = [&] {
    Eigen::VectorXd z(3);
    for (int l = 0; l < 3; ++l) {
      z(l) = std::uniform_real_distribution<double>(lower(l), upper(l))(rng);
    }
    return z;
  };
  for (int p = 0; p < 10; ++p) {
    const Eigen::VectorXd z = random_point();
    Eigen::VectorXd grad;
    PointEntropy(model, z, &grad);
    for (int l = 0; l < 3; ++l) {
      const double h = 1e-5 * (upper(l) - lower(l));
      Eigen::VectorXd zp = z, zm = z;
      zp(l) += h;
      zm(l) -= h;
      const double fd =
          (PointEntropy(model, zp, nullptr) - PointEntropy(model, zm, nullptr)) / (2 * h);
      EXPECT_NEAR(grad(l), fd, 1e-4 * std::max(1.0, std::abs(fd))) << p << " " << l;
    }
  }

  EntropySearchOptions options;
  options.seed = 11;
  const EntropySearchResult result = SearchMaxEntropy(model, lower, upper, options, {});
  ASSERT_EQ(result.z.size(), 3);
  double best_random = -1e300;
  for (int s = 0; s < 1000; ++s) {
    best_random = std::max(best_random, PointEntropy(model, random_point(), nullptr));
  }
  EXPECT_GE(result.entropy, best_random);
  EXPECT_TRUE((result.z.array() >= lower.array()).all());
  EXPECT_TRUE((result.z.array() <= upper.array()).all());
  RecordProperty("search_entropy", std::to_string(result.entropy));
  RecordProperty("best_random_entropy", std::to_string(best_random));
  RecordProperty("search_evaluations", std::to_string(result.evaluations));
}

TEST(PlannerGpTest, SteeringDerivativeCheckerOnTheGp) {
  const gp::DynamicsModel model = FittedModel(80);
  Eigen::MatrixXd inputs, states;
  CheckerStart(&inputs, &states);
  const SteeringObjective objective(Eigen::Vector2d(1.5, -2.0),
                                    Eigen::Vector2d(1.0 / 9.87, 1.0 / 64.0));
  Ipopt::SmartPtr<MultipleShootingNlp> nlp = new MultipleShootingNlp(
      model, objective, Eigen::Vector2d(0.1, -0.2), Eigen::VectorXd::Constant(1, -3.0),
      Eigen::VectorXd::Constant(1, 3.0), inputs, states);
  const std::string log = DerivativeCheckerLog(nlp);
  EXPECT_NE(log.find("No errors detected by derivative checker"), std::string::npos)
      << log;
}

TEST(PlannerGpTest, SepPlanOnTheGp) {
  const gp::DynamicsModel model = FittedModel(150);
  PlanOptions o;
  o.strategy = Strategy::kSep;
  o.horizon = 15;
  o.input_lower = Eigen::VectorXd::Constant(1, -3.0);
  o.input_upper = Eigen::VectorXd::Constant(1, 3.0);
  o.state_lower = Eigen::Vector2d(-3.14159, -8.0);
  o.state_upper = Eigen::Vector2d(3.14159, 8.0);
  Planner planner(o);
  const Eigen::VectorXd x0 = Eigen::Vector2d(0.0, 0.0);
  PlanSummary summary;
  const auto plan = planner.PlanInputs(model, x0, 0, PlanLimits{}, &summary);
  ASSERT_TRUE(plan.ok()) << plan.status();
  const int rows = static_cast<int>(plan->inputs.rows());
  EXPECT_LE(rows, 16);
  EXPECT_EQ(plan->apply_count, rows);
  EXPECT_EQ(plan->inputs(rows - 1, 0), summary.search_point(2));
  const Eigen::Vector2d target = summary.search_point.head(2);
  const Eigen::Vector2d scale(3.14159, 8.0);
  const auto distance = [&](const Eigen::VectorXd& x) {
    return (x - target).cwiseQuotient(scale).squaredNorm();
  };
  EXPECT_LE(distance(plan->states.bottomRows(1).transpose()), distance(x0));
  RecordProperty("rows", std::to_string(rows));
  RecordProperty("distance_start", std::to_string(distance(x0)));
  RecordProperty("distance_end",
                 std::to_string(distance(plan->states.bottomRows(1).transpose())));
  RecordProperty("plan_ms", std::to_string(summary.wall_time_ms));
}

}  // namespace
}  // namespace excite::plan
