#include "server/plan/entropy_objective.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace excite::plan {
namespace {

constexpr double kPi = 3.14159265358979323846;

TEST(EntropyObjectiveTest, MatchesClosedFormSummedOverEntries) {
  Eigen::MatrixXd v(2, 2);
  v << 0.5, 2.0, 1e-3, 3.0;
  double expected = 0.0;
  for (double x : {0.5, 2.0, 1e-3, 3.0}) {
    expected += 0.5 * std::log(2.0 * kPi * std::exp(1.0) * x);
  }
  EXPECT_NEAR(Entropy(v), expected, 1e-12);
}

TEST(EntropyObjectiveTest, FloorsZeroNegativeAndNanVariances) {
  Eigen::MatrixXd v(1, 3);
  v << 0.0, -1.0, std::numeric_limits<double>::quiet_NaN();
  const double h = Entropy(v);
  EXPECT_TRUE(std::isfinite(h));
  EXPECT_NEAR(h, 3 * 0.5 * std::log(2.0 * kPi * std::exp(1.0) * kVarianceFloor), 1e-9);

  Eigen::MatrixXd jac = Eigen::MatrixXd::Ones(3, 4);
  const Eigen::VectorXd g = EntropyGradient(v.row(0).transpose(), jac);
  EXPECT_TRUE(g.isZero());
}

TEST(EntropyObjectiveTest, GradientMatchesFiniteDifferences) {
  // var_j(z) = a_j + (b_j . z)^2 on z in R^3, two outputs.
  const Eigen::Matrix<double, 2, 3> b =
      (Eigen::Matrix<double, 2, 3>() << 0.3, -1.0, 0.7, 1.2, 0.4, -0.2).finished();
  const Eigen::Vector2d a(0.1, 0.05);
  const auto var = [&](const Eigen::Vector3d& z) {
    Eigen::Vector2d v;
    for (int j = 0; j < 2; ++j) v(j) = a(j) + std::pow(b.row(j).dot(z), 2);
    return v;
  };
  const Eigen::Vector3d z(0.4, -0.3, 1.1);
  Eigen::MatrixXd jac(2, 3);
  for (int j = 0; j < 2; ++j) jac.row(j) = 2.0 * b.row(j).dot(z) * b.row(j);
  const Eigen::VectorXd g = EntropyGradient(var(z), jac);
  for (int l = 0; l < 3; ++l) {
    const double h = 1e-6;
    Eigen::Vector3d zp = z, zm = z;
    zp(l) += h;
    zm(l) -= h;
    const double fd =
        (Entropy(var(zp).transpose()) - Entropy(var(zm).transpose())) / (2.0 * h);
    EXPECT_NEAR(g(l), fd, 1e-6 * std::max(1.0, std::abs(fd))) << "l=" << l;
  }
}

}  // namespace
}  // namespace excite::plan
