#include "sim/plants/two_link_arm.h"

#include <cmath>

#include "sim/plants/rk4.h"

namespace excite::sim {
namespace {

// Centre-of-mass distance and inertia about the centre of mass of a uniform rod.
double CentreOfMass(double length) { return 0.5 * length; }
double RodInertia(double mass, double length) { return mass * length * length / 12.0; }

}  // namespace

TwoLinkArm::TwoLinkArm(const TwoLinkArmParameters& parameters, double dt_s, int substeps)
    : parameters_(parameters), dt_s_(dt_s), substeps_(substeps) {}

Eigen::Matrix2d TwoLinkArm::MassMatrix(double q2) const {
  const TwoLinkArmParameters& p = parameters_;
  const double a1 = p.length1_m;
  const double l1 = CentreOfMass(p.length1_m);
  const double l2 = CentreOfMass(p.length2_m);
  const double i1 = RodInertia(p.mass1_kg, p.length1_m);
  const double i2 = RodInertia(p.mass2_kg, p.length2_m);
  const double c2 = std::cos(q2);
  Eigen::Matrix2d m;
  m(0, 0) = i1 + p.mass1_kg * l1 * l1 + i2 +
            p.mass2_kg * (a1 * a1 + l2 * l2 + 2.0 * a1 * l2 * c2);
  m(0, 1) = i2 + p.mass2_kg * (l2 * l2 + a1 * l2 * c2);
  m(1, 0) = m(0, 1);
  m(1, 1) = i2 + p.mass2_kg * l2 * l2;
  return m;
}

Eigen::Vector2d TwoLinkArm::CoriolisTorques(const Eigen::Vector2d& q,
                                            const Eigen::Vector2d& q_dot) const {
  // h = -m2 a1 l2 sin q2; C = [[h q2', h (q1' + q2')], [-h q1', 0]].
  const double h = -parameters_.mass2_kg * parameters_.length1_m *
                   CentreOfMass(parameters_.length2_m) * std::sin(q(1));
  return {h * (2.0 * q_dot(0) * q_dot(1) + q_dot(1) * q_dot(1)),
          -h * q_dot(0) * q_dot(0)};
}

Eigen::Vector2d TwoLinkArm::GravityTorques(const Eigen::Vector2d& q) const {
  const TwoLinkArmParameters& p = parameters_;
  const double l1 = CentreOfMass(p.length1_m);
  const double l2 = CentreOfMass(p.length2_m);
  const double s12 = std::sin(q(0) + q(1));
  return {(p.mass1_kg * l1 + p.mass2_kg * p.length1_m) * p.gravity * std::sin(q(0)) +
              p.mass2_kg * l2 * p.gravity * s12,
          p.mass2_kg * l2 * p.gravity * s12};
}

Eigen::Vector4d TwoLinkArm::Derivative(const Eigen::Vector4d& x,
                                       const Eigen::Vector2d& tau) const {
  const Eigen::Vector2d q = x.head<2>();
  const Eigen::Vector2d q_dot = x.tail<2>();
  const Eigen::Vector2d damping(parameters_.damping1 * q_dot(0),
                                parameters_.damping2 * q_dot(1));
  const Eigen::Vector2d rhs =
      tau - CoriolisTorques(q, q_dot) - GravityTorques(q) - damping;
  // M is symmetric positive definite (2 x 2): solve by LDLT.
  const Eigen::Vector2d q_ddot = MassMatrix(q(1)).ldlt().solve(rhs);
  Eigen::Vector4d derivative;
  derivative << q_dot, q_ddot;
  return derivative;
}

double TwoLinkArm::Energy(const Eigen::Vector4d& x) const {
  const TwoLinkArmParameters& p = parameters_;
  const Eigen::Vector2d q_dot = x.tail<2>();
  const double kinetic = 0.5 * q_dot.dot(MassMatrix(x(1)) * q_dot);
  const double l1 = CentreOfMass(p.length1_m);
  const double l2 = CentreOfMass(p.length2_m);
  const double potential =
      p.gravity * (p.mass1_kg * l1 * (1.0 - std::cos(x(0))) +
                   p.mass2_kg * (p.length1_m * (1.0 - std::cos(x(0))) +
                                 l2 * (1.0 - std::cos(x(0) + x(1)))));
  return kinetic + potential;
}

Eigen::VectorXd TwoLinkArm::Step(const Eigen::VectorXd& x,
                                 const Eigen::VectorXd& u) const {
  const Eigen::Vector2d tau(u(0), u(1));
  const auto f = [this, &tau](const Eigen::VectorXd& state) -> Eigen::VectorXd {
    return Derivative(Eigen::Vector4d(state(0), state(1), state(2), state(3)), tau);
  };
  return Rk4Integrate(f, x, dt_s_, substeps_);
}

}  // namespace excite::sim
