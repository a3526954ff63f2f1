#include "server/plan/multiple_shooting_nlp.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "server/plan/entropy_objective.h"
#include "server/plan/ipopt_solve.h"
#include "tests/plan/analytic_predictor.h"

namespace excite::plan {
namespace {

// The paper's objective (the NLP keeps a reference: it lives as long as the test).
const NegativeEntropyObjective kEntropy;

using ::excite::plan::testing::AnalyticPendulum;
using ::excite::plan::testing::WrappedPredictor;

// An NLP at a generic point: random inputs inside the bounds and states that do
// NOT satisfy the dynamics, so every Jacobian block is exercised.
Ipopt::SmartPtr<MultipleShootingNlp> MakeNlp(const gp::DynamicsPredictor& model,
                                             int horizon) {
  const int du = model.input_dim();
  const Eigen::VectorXd lower = Eigen::VectorXd::Constant(du, -2.0);
  const Eigen::VectorXd upper = Eigen::VectorXd::Constant(du, 2.0);
  Eigen::MatrixXd inputs = Eigen::MatrixXd::Random(horizon, du) * 1.5;
  Eigen::MatrixXd states = Eigen::MatrixXd::Random(horizon, 2);
  return new MultipleShootingNlp(model, kEntropy, Eigen::Vector2d(0.2, -0.1), lower,
                                 upper, inputs, states);
}

struct Dense {
  double f = 0.0;
  Eigen::VectorXd grad;
  Eigen::VectorXd g;
  Eigen::MatrixXd jac;
};

Dense EvaluateDense(MultipleShootingNlp& nlp, const Eigen::VectorXd& w) {
  Ipopt::Index n, m, nnz, nnz_h;
  Ipopt::TNLP::IndexStyleEnum style;
  EXPECT_TRUE(nlp.get_nlp_info(n, m, nnz, nnz_h, style));
  Dense d;
  d.grad.resize(n);
  d.g.resize(m);
  d.jac = Eigen::MatrixXd::Zero(m, n);
  EXPECT_TRUE(nlp.eval_f(n, w.data(), true, d.f));
  EXPECT_TRUE(nlp.eval_grad_f(n, w.data(), false, d.grad.data()));
  EXPECT_TRUE(nlp.eval_g(n, w.data(), false, m, d.g.data()));
  std::vector<Ipopt::Index> rows(nnz), cols(nnz);
  std::vector<double> values(nnz);
  EXPECT_TRUE(
      nlp.eval_jac_g(n, nullptr, false, m, nnz, rows.data(), cols.data(), nullptr));
  EXPECT_TRUE(
      nlp.eval_jac_g(n, w.data(), false, m, nnz, nullptr, nullptr, values.data()));
  for (int k = 0; k < nnz; ++k) d.jac(rows[k], cols[k]) += values[k];
  return d;
}

TEST(MultipleShootingNlpTest, SizesAndStartingPoint) {
  const AnalyticPendulum model(2);
  auto nlp = MakeNlp(model, 5);
  Ipopt::Index n, m, nnz, nnz_h;
  Ipopt::TNLP::IndexStyleEnum style;
  ASSERT_TRUE(nlp->get_nlp_info(n, m, nnz, nnz_h, style));
  EXPECT_EQ(n, 5 * 2 + 4 * 2);
  EXPECT_EQ(m, 4 * 2);
  EXPECT_EQ(nnz, 4 * 2 * (1 + 2) + 3 * 2 * 2);
  std::vector<double> xl(n), xu(n), gl(m), gu(m);
  ASSERT_TRUE(nlp->get_bounds_info(n, xl.data(), xu.data(), m, gl.data(), gu.data()));
  EXPECT_EQ(xl[nlp->InputOffset(3) + 1], -2.0);
  EXPECT_EQ(xu[nlp->InputOffset(3) + 1], 2.0);
  EXPECT_LE(xl[nlp->StateOffset(2)], -1e19);
}

// Our own central differences against eval_grad_f / eval_jac_g (dense).
TEST(MultipleShootingNlpTest, DerivativesMatchCentralDifferences) {
  for (int du : {1, 2}) {
    for (int horizon : {1, 2, 6}) {
      const AnalyticPendulum model(du);
      auto nlp = MakeNlp(model, horizon);
      const Eigen::VectorXd w = nlp->StartingPoint();
      const Dense at = EvaluateDense(*nlp, w);
      const double h = 1e-6;
      double worst = 0.0;
      for (int k = 0; k < w.size(); ++k) {
        Eigen::VectorXd wp = w, wm = w;
        wp(k) += h;
        wm(k) -= h;
        const Dense p = EvaluateDense(*nlp, wp);
        const Dense q = EvaluateDense(*nlp, wm);
        const double fd = (p.f - q.f) / (2 * h);
        worst = std::max(worst, std::abs(at.grad(k) - fd) / std::max(1.0, std::abs(fd)));
        EXPECT_NEAR(at.grad(k), fd, 1e-6 * std::max(1.0, std::abs(fd)))
            << "du=" << du << " M=" << horizon << " k=" << k;
        const Eigen::VectorXd fd_col = (p.g - q.g) / (2 * h);
        for (int r = 0; r < fd_col.size(); ++r) {
          EXPECT_NEAR(at.jac(r, k), fd_col(r), 1e-6 * std::max(1.0, std::abs(fd_col(r))))
              << "du=" << du << " M=" << horizon << " row=" << r << " col=" << k;
        }
      }
      RecordProperty(
          "worst_rel_grad_error_du" + std::to_string(du) + "_M" + std::to_string(horizon),
          std::to_string(worst));
    }
  }
}

std::string RunIpoptDerivativeChecker(const gp::DynamicsPredictor& model) {
  auto nlp = MakeNlp(model, 6);
  IpoptSettings settings;
  settings.max_iterations = 0;
  settings.string_options = {{"derivative_test", "first-order"},
                             {"derivative_test_print_all", "no"}};
  std::string log;
  settings.log = &log;
  settings.log_level = 4;  // J_WARNING: the checker reports errors at this level
  const IpoptOutcome outcome = SolveTnlp(nlp, settings);
  EXPECT_TRUE(outcome.options_accepted);
  return log;
}

TEST(MultipleShootingNlpTest, IpoptDerivativeCheckerFindsNoErrors) {
  const AnalyticPendulum model(2);
  const std::string log = RunIpoptDerivativeChecker(model);
  EXPECT_NE(log.find("No errors detected by derivative checker"), std::string::npos)
      << log;
  EXPECT_EQ(log.find("Derivative checker detected"), std::string::npos) << log;
}

TEST(MultipleShootingNlpTest, IpoptDerivativeCheckerCatchesWrongGradient) {
  const AnalyticPendulum model(2);
  const WrappedPredictor wrong_variance(model, 1.0, 1.3);
  const std::string log = RunIpoptDerivativeChecker(wrong_variance);
  EXPECT_NE(log.find("Derivative checker detected"), std::string::npos) << log;
  EXPECT_NE(log.find("grad_f"), std::string::npos) << log;
}

TEST(MultipleShootingNlpTest, IpoptDerivativeCheckerCatchesWrongJacobian) {
  const AnalyticPendulum model(2);
  const WrappedPredictor wrong_mean(model, 1.1, 1.0);
  const std::string log = RunIpoptDerivativeChecker(wrong_mean);
  EXPECT_NE(log.find("Derivative checker detected"), std::string::npos) << log;
  EXPECT_NE(log.find("jac_g"), std::string::npos) << log;
}

TEST(MultipleShootingNlpTest, SolveKeepsFeasibleBestAndRespectsBounds) {
  const AnalyticPendulum model(1);
  const int horizon = 8;
  const Eigen::VectorXd lower = Eigen::VectorXd::Constant(1, -1.0);
  const Eigen::VectorXd upper = Eigen::VectorXd::Constant(1, 1.5);
  // Start from a rollout of zero inputs: feasible from the first evaluation.
  Eigen::MatrixXd inputs = Eigen::MatrixXd::Zero(horizon, 1);
  Eigen::MatrixXd states(horizon, 2);
  Eigen::VectorXd x = Eigen::Vector2d(0.1, 0.0);
  const Eigen::VectorXd x0 = x;
  for (int i = 0; i < horizon; ++i) {
    states.row(i) = x.transpose();
    Eigen::MatrixXd z(1, 3), mean, var;
    z << x.transpose(), inputs(i, 0);
    model.Predict(z, &mean, &var, nullptr, nullptr);
    x = mean.row(0).transpose();
  }
  Ipopt::SmartPtr<MultipleShootingNlp> nlp =
      new MultipleShootingNlp(model, kEntropy, x0, lower, upper, inputs, states);
  IpoptSettings settings;
  settings.max_iterations = 200;
  const IpoptOutcome outcome = SolveTnlp(nlp, settings);
  EXPECT_EQ(outcome.status, Ipopt::Solve_Succeeded);
  EXPECT_GT(nlp->iterations(), 0);
  ASSERT_EQ(nlp->best_feasible().size(), nlp->num_variables());
  ASSERT_EQ(nlp->final_point().size(), nlp->num_variables());
  const Eigen::MatrixXd u = nlp->InputsOf(nlp->final_point());
  EXPECT_GE(u.minCoeff(), -1.0 - 1e-9);
  EXPECT_LE(u.maxCoeff(), 1.5 + 1e-9);
  // The optimum is better than the zero-input start.
  Eigen::MatrixXd z0(horizon, 3), mean, var;
  z0 << states, inputs;
  model.Predict(z0, &mean, &var, nullptr, nullptr);
  EXPECT_LT(nlp->best_feasible_objective(), -Entropy(var) - 1.0);
}

TEST(MultipleShootingNlpTest, StopFunctionEndsTheSolve) {
  const AnalyticPendulum model(1);
  int polls = 0;
  Ipopt::SmartPtr<MultipleShootingNlp> nlp = new MultipleShootingNlp(
      model, kEntropy, Eigen::Vector2d(0.1, 0.0), Eigen::VectorXd::Constant(1, -1.0),
      Eigen::VectorXd::Constant(1, 1.0), Eigen::MatrixXd::Constant(10, 1, 0.3),
      Eigen::MatrixXd::Zero(10, 2), [&polls] { return ++polls >= 3; });
  const IpoptOutcome outcome = SolveTnlp(nlp, IpoptSettings{});
  EXPECT_EQ(outcome.status, Ipopt::User_Requested_Stop);
  EXPECT_TRUE(nlp->stopped());
  EXPECT_EQ(polls, 3);
  EXPECT_EQ(nlp->final_point().size(), nlp->num_variables());
}

}  // namespace
}  // namespace excite::plan
