// The held-out plants (acrobot, cart-pole, Duffing) against their energy: the
// rate of change of the energy along the vector field is the power of the input
// (minus the damping's loss), at any state; without input a long RK4 run keeps
// the energy; the equilibria are at rest.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <functional>
#include <random>

#include "sim/plants/acrobot.h"
#include "sim/plants/cart_pole.h"
#include "sim/plants/duffing.h"

namespace excite::sim {
namespace {

// dE/dt = grad E . f(x, u), the gradient by central differences (error ~1e-10
// relative at step 1e-5 for these smooth energies).
double EnergyRate(const Rk4Plant& plant,
                  const std::function<double(const Eigen::VectorXd&)>& energy,
                  const Eigen::VectorXd& x, const Eigen::VectorXd& u) {
  const Eigen::VectorXd f = plant.Derivative(x, u);
  double rate = 0.0;
  const double h = 1e-5;
  for (Eigen::Index i = 0; i < x.size(); ++i) {
    Eigen::VectorXd plus = x, minus = x;
    plus(i) += h;
    minus(i) -= h;
    rate += (energy(plus) - energy(minus)) / (2 * h) * f(i);
  }
  return rate;
}

Eigen::VectorXd RandomState(std::mt19937_64& rng, int dim, double scale) {
  std::uniform_real_distribution<double> u(-scale, scale);
  Eigen::VectorXd x(dim);
  for (int i = 0; i < dim; ++i) x(i) = u(rng);
  return x;
}

TEST(AcrobotTest, EnergyChangesByTheElbowsPowerOnly) {
  const Acrobot plant(AcrobotParameters(), 0.1, 10);
  auto energy = [&](const Eigen::VectorXd& x) { return plant.Energy(x); };
  std::mt19937_64 rng(1);
  for (int k = 0; k < 20; ++k) {
    const Eigen::VectorXd x = RandomState(rng, 4, 4.0);
    const Eigen::VectorXd u = RandomState(rng, 1, 1.0);
    EXPECT_NEAR(EnergyRate(plant, energy, x, u), u(0) * x(3),
                1e-6 * (1 + x.squaredNorm()))
        << x.transpose();
  }
}

TEST(AcrobotTest, KeepsItsEnergyWithoutTorqueAndRestsHangingDown) {
  const Acrobot plant(AcrobotParameters(), 0.1, 20);
  Eigen::VectorXd x(4);
  x << 1.0, -0.5, 0.3, 0.8;
  const double e0 = plant.Energy(x);
  for (int k = 0; k < 200; ++k) x = plant.Step(x, Eigen::VectorXd::Zero(1));
  EXPECT_NEAR(plant.Energy(x), e0, 1e-6 * std::abs(e0));
  EXPECT_LT(plant.Derivative(Eigen::VectorXd::Zero(4), Eigen::VectorXd::Zero(1)).norm(),
            1e-15);
  // Both links up (q1 = pi, q2 = 0) is an equilibrium too, an unstable one.
  EXPECT_LT(
      plant.Derivative(Eigen::Vector4d(M_PI, 0, 0, 0), Eigen::VectorXd::Zero(1)).norm(),
      1e-12);
}

TEST(CartPoleTest, EnergyChangesByTheForcesPowerOnly) {
  const CartPole plant(CartPoleParameters(), 0.08, 10);
  auto energy = [&](const Eigen::VectorXd& x) { return plant.Energy(x); };
  std::mt19937_64 rng(2);
  for (int k = 0; k < 20; ++k) {
    const Eigen::VectorXd x = RandomState(rng, 4, 4.0);
    const Eigen::VectorXd u = RandomState(rng, 1, 10.0);
    EXPECT_NEAR(EnergyRate(plant, energy, x, u), u(0) * x(2),
                1e-6 * (1 + x.squaredNorm()))
        << x.transpose();
  }
}

TEST(CartPoleTest, KeepsItsEnergyWithoutForceAndRestsHangingDown) {
  const CartPole plant(CartPoleParameters(), 0.08, 20);
  Eigen::VectorXd x(4);
  x << 0.2, 2.5, -0.4, 1.5;
  const double e0 = plant.Energy(x);
  for (int k = 0; k < 200; ++k) x = plant.Step(x, Eigen::VectorXd::Zero(1));
  EXPECT_NEAR(plant.Energy(x), e0, 1e-6 * std::abs(e0));
  EXPECT_LT(
      plant.Derivative(Eigen::Vector4d(0.7, M_PI, 0, 0), Eigen::VectorXd::Zero(1)).norm(),
      1e-12);
  // Small swings about the bottom: a physical pendulum of length 4/3 l whose
  // pivot moves (the cart recoils), period 2 pi sqrt(l (4/3 - m_p / M) / g).
  const CartPoleParameters p;
  const double total = p.cart_mass_kg + p.pole_mass_kg;
  const double period =
      2 * M_PI *
      std::sqrt(p.pole_half_length_m * (4.0 / 3.0 - p.pole_mass_kg / total) / p.gravity);
  const CartPole fine(p, period / 400, 10);
  Eigen::VectorXd y(4);
  y << 0.0, M_PI + 1e-4, 0.0, 0.0;
  for (int k = 0; k < 400; ++k) y = fine.Step(y, Eigen::VectorXd::Zero(1));
  EXPECT_NEAR(y(1) - M_PI, 1e-4, 1e-8);  // back where it started after one period
}

TEST(DuffingTest, EnergyChangesByForcingMinusDamping) {
  const DuffingParameters p;
  const Duffing plant(p, 0.2, 10);
  auto energy = [&](const Eigen::VectorXd& x) { return plant.Energy(x); };
  std::mt19937_64 rng(3);
  for (int k = 0; k < 20; ++k) {
    const Eigen::VectorXd x = RandomState(rng, 2, 2.0);
    const Eigen::VectorXd u = RandomState(rng, 1, 0.5);
    EXPECT_NEAR(EnergyRate(plant, energy, x, u), u(0) * x(1) - p.damping * x(1) * x(1),
                1e-8)
        << x.transpose();
  }
  // The wells' bottoms x = +-sqrt(-alpha / beta) = +-1 are at rest.
  for (double bottom : {-1.0, 1.0}) {
    EXPECT_LT(
        plant.Derivative(Eigen::Vector2d(bottom, 0), Eigen::VectorXd::Zero(1)).norm(),
        1e-15);
  }
}

}  // namespace
}  // namespace excite::sim
