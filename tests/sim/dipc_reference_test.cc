// The MuJoCo double inverted pendulum on a cart (sim/plants/models/dipc.xml) against
// an independent model: the Lagrangian equations of a cart and two capsule poles,
// with masses and inertias from the capsules' closed form (density 1000), the MJCF's
// damping and gear, integrated here with RK4. Agreement to 1e-6 over a second of
// large swings checks the MJCF (geometry, joint axes and angle conventions) and the
// plant's state maps, not only that MuJoCo runs.

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <memory>

#include "sim/plants/dipc.h"

namespace excite::sim {
namespace {

constexpr double kDensity = 1000.0;  // MJCF default geom density
constexpr double kGravity = 9.81;

// Mass, centre-of-mass offset along the axis and moment of inertia about a
// transverse axis through the centre of mass, of a capsule with cylinder length h
// and radius r: a cylinder plus two hemispheres.
struct Capsule {
  double mass, com, transverse_inertia;
};

Capsule CapsuleOf(double h, double r) {
  const double cylinder = kDensity * M_PI * r * r * h;
  const double spheres = kDensity * 4.0 / 3.0 * M_PI * r * r * r;
  // Each hemisphere: 2/5 m r^2 about its flat face's centre, shifted by h/2 along
  // the axis (its centroid sits 3r/8 beyond the face).
  const double inertia = cylinder * (3 * r * r + h * h) / 12 +
                         spheres * (2 * r * r / 5 + h * h / 4 + 3 * h * r / 8);
  return {cylinder + spheres, h / 2, inertia};
}

// q = (p, a1, a2): cart position, pole 1's angle from upright, pole 2's angle
// relative to pole 1 (rotations about +y: a pole's tip direction is (sin a, cos a)
// in the x-z plane).
class ReferenceDipc {
 public:
  ReferenceDipc()
      : cart_(CapsuleOf(0.2, 0.1)), pole_(CapsuleOf(0.6, 0.045)), length_(0.6) {}

  double cart_mass() const { return cart_.mass; }
  const Capsule& pole() const { return pole_; }

  Eigen::Matrix3d MassMatrix(const Eigen::Vector3d& q) const {
    const double a1 = q(1), a12 = q(1) + q(2), c = pole_.com, l = length_;
    Eigen::Matrix<double, 2, 3> j1, j2;  // x and z velocity Jacobians of the COMs
    j1 << 1, c * std::cos(a1), 0,        //
        0, -c * std::sin(a1), 0;
    j2 << 1, l * std::cos(a1) + c * std::cos(a12), c * std::cos(a12),  //
        0, -l * std::sin(a1) - c * std::sin(a12), -c * std::sin(a12);
    const Eigen::RowVector3d w1(0, 1, 0), w2(0, 1, 1);  // angular velocities
    Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
    m(0, 0) = cart_.mass;
    m += pole_.mass * (j1.transpose() * j1 + j2.transpose() * j2);
    m += pole_.transverse_inertia * (w1.transpose() * w1 + w2.transpose() * w2);
    return m;
  }

  // dV/dq of the gravity potential.
  Eigen::Vector3d GravityGradient(const Eigen::Vector3d& q) const {
    const double a1 = q(1), a12 = q(1) + q(2), c = pole_.com, l = length_;
    const double m = pole_.mass;
    return {0.0,
            -kGravity * m * (c * std::sin(a1) + l * std::sin(a1) + c * std::sin(a12)),
            -kGravity * m * c * std::sin(a12)};
  }

  // (q, q') -> (q', q'') with input u (force 500 u on the cart) and the MJCF's
  // viscous damping (8 on the slider, 1 on each hinge, on each joint's own rate).
  Eigen::Matrix<double, 6, 1> Derivative(const Eigen::Matrix<double, 6, 1>& s,
                                         double u) const {
    const Eigen::Vector3d q = s.head<3>(), v = s.tail<3>();
    // Coriolis and centrifugal terms M'(q) v - 1/2 d/dq (v' M v), with dM/dq_k by
    // central differences (M is a trigonometric polynomial: error ~1e-11).
    Eigen::Vector3d coriolis = Eigen::Vector3d::Zero();
    constexpr double kH = 1e-5;
    for (int k = 0; k < 3; ++k) {
      Eigen::Vector3d dq = Eigen::Vector3d::Zero();
      dq(k) = kH;
      const Eigen::Matrix3d dm = (MassMatrix(q + dq) - MassMatrix(q - dq)) / (2 * kH);
      coriolis += dm * v * v(k);
      coriolis(k) -= 0.5 * v.dot(dm * v);
    }
    const Eigen::Vector3d damping(8.0 * v(0), 1.0 * v(1), 1.0 * v(2));
    const Eigen::Vector3d force(500.0 * u, 0.0, 0.0);
    Eigen::Matrix<double, 6, 1> ds;
    ds << v, MassMatrix(q).ldlt().solve(force - coriolis - GravityGradient(q) - damping);
    return ds;
  }

  Eigen::Matrix<double, 6, 1> Integrate(Eigen::Matrix<double, 6, 1> s, double u,
                                        double seconds, int steps) const {
    const double h = seconds / steps;
    for (int i = 0; i < steps; ++i) {
      const auto k1 = Derivative(s, u);
      const auto k2 = Derivative(s + 0.5 * h * k1, u);
      const auto k3 = Derivative(s + 0.5 * h * k2, u);
      const auto k4 = Derivative(s + h * k3, u);
      s += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
    }
    return s;
  }

 private:
  Capsule cart_;
  Capsule pole_;
  double length_;  // hinge 1 to hinge 2
};

TEST(DipcReferenceTest, MassPropertiesAreTheCapsulesClosedForm) {
  absl::StatusOr<std::unique_ptr<Dipc>> dipc = Dipc::Create(0.01, 10);
  ASSERT_TRUE(dipc.ok()) << dipc.status();
  const mjModel& m = (*dipc)->model();
  const ReferenceDipc ref;
  ASSERT_EQ(m.nbody, 4);  // world, cart, pole1, pole2
  EXPECT_NEAR(m.body_mass[1], ref.cart_mass(), 1e-9 * ref.cart_mass());
  for (int b = 2; b <= 3; ++b) {
    EXPECT_NEAR(m.body_mass[b], ref.pole().mass, 1e-9 * ref.pole().mass);
    EXPECT_NEAR(m.body_ipos[3 * b + 2], ref.pole().com, 1e-12);
    // Principal moments: the transverse one twice (the axial one is smaller).
    const double* inertia = m.body_inertia + 3 * b;
    const double transverse = *std::max_element(inertia, inertia + 3);
    EXPECT_NEAR(transverse, ref.pole().transverse_inertia,
                1e-9 * ref.pole().transverse_inertia);
  }
}

// One second from a swinging, moving state with a constant push, and from rest
// hanging with a push: MuJoCo (RK4, 1 ms) and the reference (RK4, 0.1 ms) agree.
TEST(DipcReferenceTest, TrajectoriesMatchTheLagrangianModel) {
  absl::StatusOr<std::unique_ptr<Dipc>> dipc = Dipc::Create(0.01, 10);
  ASSERT_TRUE(dipc.ok()) << dipc.status();
  const ReferenceDipc ref;
  struct Case {
    double p, a1, a2, p_dot, a1_dot, a2_dot, u;
  };
  for (const Case& c : {Case{0.1, M_PI - 0.8, 0.5, 0.2, -1.0, 2.0, 0.02},
                        Case{-0.3, M_PI, 0.0, 0.0, 0.0, 0.0, -0.03},
                        Case{0.0, 2.0, -1.0, -0.1, 3.0, -2.0, 0.0}}) {
    Eigen::VectorXd x = Dipc::StateOf(c.p, c.a1, c.a2, c.p_dot, c.a1_dot, c.a2_dot);
    const Eigen::VectorXd u = Eigen::VectorXd::Constant(1, c.u);
    for (int k = 0; k < 100; ++k) x = (*dipc)->Step(x, u);  // 100 x 0.01 s
    Eigen::Matrix<double, 6, 1> s;
    s << c.p, c.a1, c.a2, c.p_dot, c.a1_dot, c.a2_dot;
    s = ref.Integrate(s, c.u, 1.0, 10000);
    const Eigen::VectorXd expected = Dipc::StateOf(s(0), s(1), s(2), s(3), s(4), s(5));
    ASSERT_LT(std::abs(s(0)), 1.9) << "the reference must stay off the rail's ends";
    EXPECT_LT((x - expected).cwiseAbs().maxCoeff(), 1e-6)
        << "mujoco   " << x.transpose() << "\nreference " << expected.transpose();
    // The motion is large: the check is not passed by staying still.
    EXPECT_GT((expected - Dipc::StateOf(c.p, c.a1, c.a2, c.p_dot, c.a1_dot, c.a2_dot))
                  .cwiseAbs()
                  .maxCoeff(),
              0.1);
  }
}

}  // namespace
}  // namespace excite::sim
