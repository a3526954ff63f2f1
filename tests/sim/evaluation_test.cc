#include "sim/evaluation.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "sim/plants/pendulum.h"

namespace excite::sim {
namespace {

// x_{k+1} = x_k + 2 u_k, one state and one input: easy to check by hand.
class AddPlant : public Plant {
 public:
  std::string name() const override { return "add"; }
  int state_dim() const override { return 1; }
  int input_dim() const override { return 1; }
  Eigen::VectorXd Step(const Eigen::VectorXd& x,
                       const Eigen::VectorXd& u) const override {
    return x + 2.0 * u;
  }
};

// State (v, sin a, cos a): one angle held as (sin, cos) after a plain dimension.
class AnglePlant : public Plant {
 public:
  std::string name() const override { return "angle"; }
  int state_dim() const override { return 3; }
  int input_dim() const override { return 1; }
  Eigen::VectorXd Step(const Eigen::VectorXd& x,
                       const Eigen::VectorXd& /*u*/) const override {
    return x;
  }
  std::vector<std::pair<int, int>> AnglePairs() const override { return {{1, 2}}; }
};

Box MakeBox(std::initializer_list<double> lower, std::initializer_list<double> upper) {
  Box box;
  box.lower = Eigen::Map<const Eigen::VectorXd>(lower.begin(), lower.size());
  box.upper = Eigen::Map<const Eigen::VectorXd>(upper.begin(), upper.size());
  return box;
}

TEST(RmseTest, HandComputed) {
  Eigen::MatrixXd predicted(2, 2);
  predicted << 1.0, 0.0,  //
      0.0, 0.0;
  Eigen::MatrixXd truth(2, 2);
  truth << 0.0, 0.0,  //
      0.0, 2.0;
  // Point errors: ||(1, 0)||^2 = 1, ||(0, -2)||^2 = 4; mean 2.5.
  absl::StatusOr<double> rmse = Rmse(predicted, truth);
  ASSERT_TRUE(rmse.ok());
  EXPECT_DOUBLE_EQ(*rmse, std::sqrt(2.5));
  // Per dimension: errors (1, 0) and (0, -2): sqrt(1/2) and sqrt(4/2).
  absl::StatusOr<Eigen::VectorXd> per_dimension = RmsePerDimension(predicted, truth);
  ASSERT_TRUE(per_dimension.ok());
  ASSERT_EQ(per_dimension->size(), 2);
  EXPECT_DOUBLE_EQ((*per_dimension)(0), std::sqrt(0.5));
  EXPECT_DOUBLE_EQ((*per_dimension)(1), std::sqrt(2.0));
  EXPECT_DOUBLE_EQ(per_dimension->squaredNorm(), 2.5);
  EXPECT_FALSE(RmsePerDimension(predicted, Eigen::MatrixXd(2, 3)).ok());
}

// An angle's error is the shorter way round: 3.1 against -3.1 is 0.083 off,
// not 6.2, and a prediction one turn off is exact.
TEST(RmseTest, AnglesAreComparedOnTheCircle) {
  Eigen::MatrixXd predicted(2, 2), truth(2, 2);
  predicted << 3.1, 1.0,  //
      0.5 + 2 * M_PI, 2.0;
  truth << -3.1, 1.0,  //
      0.5, 2.5;
  const double wrapped = 6.2 - 2 * M_PI;  // -0.0832
  const Eigen::MatrixXd errors = PredictionErrors(predicted, truth, {0});
  EXPECT_NEAR(errors(0, 0), wrapped, 1e-12);
  EXPECT_NEAR(errors(1, 0), 0.0, 1e-12);
  EXPECT_DOUBLE_EQ(errors(1, 1), -0.5);
  EXPECT_NEAR(*Rmse(predicted, truth, {0}), std::sqrt((wrapped * wrapped + 0.25) / 2.0),
              1e-12);
  absl::StatusOr<Eigen::VectorXd> per_dimension = RmsePerDimension(predicted, truth, {0});
  ASSERT_TRUE(per_dimension.ok());
  EXPECT_NEAR((*per_dimension)(0), std::abs(wrapped) / std::sqrt(2.0), 1e-12);
  EXPECT_GT(*Rmse(predicted, truth), 4.0);  // without angle_dims: a turn off
}

// Coverage and boxes see where on the circle a state is: a pendulum that went
// round five times covers the bins of the turn it is in now.
TEST(CoverageTest, AnglesCountOnTheirTurnOfTheRegion) {
  Eigen::MatrixXd visited(3, 2);
  visited << 0.1 + 10 * M_PI, 0.5,  //
      -0.1 - 4 * M_PI, 0.5,         //
      M_PI, 0.5;                    // the region's upper end itself
  const Box region = MakeBox({-M_PI, 0.0}, {M_PI, 1.0});
  const Eigen::MatrixXd on = OnTheCircle(visited, region.lower, {0});
  EXPECT_NEAR(on(0, 0), 0.1, 1e-9);
  EXPECT_NEAR(on(1, 0), -0.1, 1e-9);
  EXPECT_NEAR(on(2, 0), -M_PI, 1e-12);  // [lower, lower + 2 pi): pi is -pi
  EXPECT_EQ(on.col(1), visited.col(1));
  absl::StatusOr<Coverage> coverage = ComputeCoverage(on, region, 4, 2);
  ASSERT_TRUE(coverage.ok());
  // Angle bins of pi / 2: {2, 1, 0} -> 3/4; the rate: bin 2 of 4 -> 1/4.
  EXPECT_DOUBLE_EQ(coverage->marginal, 0.5);
  EXPECT_EQ(FractionOutside(on, region), 0.0);
  EXPECT_GT(FractionOutside(visited, region), 0.5);
}

// Hand-computed: errors 0, 1 and 3 (the last an angle predicted 3 + 2 pi) against
// standard deviations 1, 1 and 1.5: the third is outside its 95 % interval (2.94).
TEST(CalibrationTest, HandComputed) {
  Eigen::MatrixXd mean(1, 3), variance(1, 3), truth(1, 3);
  mean << 1.0, 2.0, 3.0 + 2 * M_PI;
  truth << 1.0, 1.0, 0.0;
  variance << 1.0, 1.0, 2.25;
  const Calibration c = ComputeCalibration(mean, variance, truth, {2});
  const double log2pi = std::log(2 * M_PI);
  const double expected =
      (0.5 * log2pi + (0.5 * log2pi + 0.5) + (0.5 * (log2pi + std::log(2.25)) + 2.0)) /
      3.0;
  EXPECT_NEAR(c.nlpd, expected, 1e-12);
  EXPECT_DOUBLE_EQ(c.inside_95, 2.0 / 3.0);
  // Without angle_dims the third error is 3 + 2 pi: far outside.
  EXPECT_GT(ComputeCalibration(mean, variance, truth, {}).nlpd, c.nlpd + 5.0);
}

// Each rollout is the plant driven by its inputs from its start; the same seed
// gives the same set.
TEST(RolloutSetTest, TrajectoriesOfThePlant) {
  const Pendulum pendulum(PendulumParameters(), 0.1, 10);
  const Plant* plant = &pendulum;
  const Box region = MakeBox({-M_PI, -8.0}, {M_PI, 8.0});
  const Box inputs = MakeBox({-3.0}, {3.0});
  absl::StatusOr<RolloutSet> set = MakeRolloutSet(*plant, region, inputs, 4, 6, 7);
  ASSERT_TRUE(set.ok()) << set.status();
  ASSERT_EQ(set->states.size(), 7u);
  ASSERT_EQ(set->inputs.size(), 6u);
  for (int k = 0; k < 6; ++k) {
    for (int r = 0; r < 4; ++r) {
      const Eigen::VectorXd next = plant->Step(set->states[k].row(r).transpose(),
                                               set->inputs[k].row(r).transpose());
      EXPECT_EQ(set->states[k + 1].row(r), next.transpose());
      EXPECT_LE(std::abs(set->inputs[k](r, 0)), 3.0);
    }
  }
  absl::StatusOr<RolloutSet> again = MakeRolloutSet(*plant, region, inputs, 4, 6, 7);
  EXPECT_EQ(again->states[6], set->states[6]);
  EXPECT_FALSE(MakeRolloutSet(*plant, region, inputs, 0, 6, 7).ok());
}

TEST(RmseTest, ZeroForPerfectPrediction) {
  const Eigen::MatrixXd truth = Eigen::MatrixXd::Random(5, 3);
  EXPECT_EQ(*Rmse(truth, truth), 0.0);
}

TEST(RmseTest, ShapeMismatchAndEmpty) {
  EXPECT_EQ(Rmse(Eigen::MatrixXd(2, 2), Eigen::MatrixXd(2, 3)).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(Rmse(Eigen::MatrixXd(0, 2), Eigen::MatrixXd(0, 2)).status().code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(EvaluationSetTest, PointsInBoxesAndTrueNextStates) {
  const AddPlant plant;
  const Box region = MakeBox({-1.0}, {3.0});
  const Box inputs = MakeBox({0.5}, {0.75});
  absl::StatusOr<EvaluationSet> set = MakeEvaluationSet(plant, region, inputs, 200, 42);
  ASSERT_TRUE(set.ok()) << set.status();
  ASSERT_EQ(set->inputs.rows(), 200);
  ASSERT_EQ(set->inputs.cols(), 2);
  ASSERT_EQ(set->next_states.rows(), 200);
  ASSERT_EQ(set->next_states.cols(), 1);
  for (int p = 0; p < 200; ++p) {
    const double x = set->inputs(p, 0);
    const double u = set->inputs(p, 1);
    EXPECT_GE(x, -1.0);
    EXPECT_LT(x, 3.0);
    EXPECT_GE(u, 0.5);
    EXPECT_LT(u, 0.75);
    EXPECT_DOUBLE_EQ(set->next_states(p, 0), x + 2.0 * u);
  }
  // Spread over the region, not stuck in a corner.
  EXPECT_NEAR(set->inputs.col(0).mean(), 1.0, 0.4);
}

// Angle pairs are drawn as angles: every point on the unit circle, uniform over
// the arc the bounds allow (here cos <= 0: the left half circle, a in [pi/2, 3pi/2]).
TEST(EvaluationSetTest, AnglePairsAreDrawnOnTheirArc) {
  const AnglePlant plant;
  const Box region = MakeBox({-2.0, -1.0, -1.0}, {2.0, 1.0, 0.0});
  const Box inputs = MakeBox({0.0}, {1.0});
  absl::StatusOr<EvaluationSet> set = MakeEvaluationSet(plant, region, inputs, 2000, 3);
  ASSERT_TRUE(set.ok()) << set.status();
  int upper_half = 0;
  double mean_angle = 0.0;
  for (int p = 0; p < 2000; ++p) {
    const double s = set->inputs(p, 1);
    const double c = set->inputs(p, 2);
    EXPECT_NEAR(s * s + c * c, 1.0, 1e-12);
    EXPECT_LE(c, 0.0);
    upper_half += s > 0.0 ? 1 : 0;
    // The angle in [pi/2, 3pi/2]: uniform there has mean pi and std pi/sqrt(12).
    mean_angle += std::atan2(s, c) < 0 ? std::atan2(s, c) + 2 * M_PI : std::atan2(s, c);
  }
  mean_angle /= 2000;
  EXPECT_NEAR(upper_half, 1000, 100);
  EXPECT_NEAR(mean_angle, M_PI, 0.1);
  // The plain dimension stays uniform in its interval.
  EXPECT_NEAR(set->inputs.col(0).mean(), 0.0, 0.15);
  EXPECT_GE(set->inputs.col(0).minCoeff(), -2.0);
  // An arc that does not exist (sin >= 0.5 needs cos <= 0.87): an error naming it.
  const Box empty = MakeBox({-2.0, 0.5, 0.9}, {2.0, 1.0, 1.0});
  absl::StatusOr<EvaluationSet> none = MakeEvaluationSet(plant, empty, inputs, 5, 3);
  EXPECT_EQ(none.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(none.status().message().find("dimensions 1 and 2"), std::string::npos)
      << none.status();
}

TEST(EvaluationSetTest, SameSeedSameSetOtherSeedOtherSet) {
  const AddPlant plant;
  const Box region = MakeBox({0.0}, {1.0});
  const Box inputs = MakeBox({0.0}, {1.0});
  const EvaluationSet a = *MakeEvaluationSet(plant, region, inputs, 10, 7);
  const EvaluationSet b = *MakeEvaluationSet(plant, region, inputs, 10, 7);
  const EvaluationSet c = *MakeEvaluationSet(plant, region, inputs, 10, 8);
  EXPECT_EQ(a.inputs, b.inputs);
  EXPECT_NE(a.inputs, c.inputs);
}

TEST(EvaluationSetTest, Errors) {
  const AddPlant plant;
  const Box ok = MakeBox({0.0}, {1.0});
  EXPECT_EQ(MakeEvaluationSet(plant, ok, ok, 0, 1).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(
      MakeEvaluationSet(plant, MakeBox({0.0, 0.0}, {1.0, 1.0}), ok, 5, 1).status().code(),
      absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(MakeEvaluationSet(plant, ok, MakeBox({1.0}, {1.0}), 5, 1).status().code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(FractionOutsideTest, HandComputed) {
  const Box box{Eigen::Vector2d(-1.0, 0.0), Eigen::Vector2d(1.0, 2.0)};
  Eigen::MatrixXd visited(4, 2);
  visited << 0.0, 1.0,  // inside
      1.0, 2.0,         // on the upper corner: inside
      -1.5, 1.0,        // left of the box
      0.0, 2.5;         // above it
  EXPECT_DOUBLE_EQ(FractionOutside(visited, box), 0.5);
  EXPECT_EQ(FractionOutside(Eigen::MatrixXd(0, 2), box), 0.0);
}

TEST(CoverageTest, HandComputedTwoDimensions) {
  // Region [0, 1] x [0, 1].
  Eigen::MatrixXd visited(4, 2);
  visited << 0.1, 0.1,  //
      0.3, 0.9,         //
      1.0, 1.0,         // On the upper boundary: last bin.
      2.0, 0.5;         // theta outside: no bin in dim 0 nor joint; dim 1 counts.
  // Marginal, 4 bins of 0.25: dim 0 hits bins {0, 1, 3} -> 3/4; dim 1 hits
  // {0, 3, 3, 2} -> 3/4; mean 0.75.
  // Joint, 3 x 3 cells: (0, 0), (0, 2), (2, 2) -> 3/9.
  absl::StatusOr<Coverage> coverage =
      ComputeCoverage(visited, MakeBox({0.0, 0.0}, {1.0, 1.0}), 4, 3);
  ASSERT_TRUE(coverage.ok()) << coverage.status();
  EXPECT_DOUBLE_EQ(coverage->marginal, 0.75);
  ASSERT_TRUE(coverage->joint.has_value());
  EXPECT_DOUBLE_EQ(*coverage->joint, 1.0 / 3.0);
}

TEST(CoverageTest, DifferentMarginalsAreAveraged) {
  // Region [-1, 1] x [0, 10], 2 bins each: dim 0 hits both, dim 1 only the first.
  Eigen::MatrixXd visited(2, 2);
  visited << -0.5, 1.0,  //
      0.5, 2.0;
  const Coverage coverage =
      *ComputeCoverage(visited, MakeBox({-1.0, 0.0}, {1.0, 10.0}), 2, 2);
  EXPECT_DOUBLE_EQ(coverage.marginal, (1.0 + 0.5) / 2.0);
  EXPECT_DOUBLE_EQ(*coverage.joint, 2.0 / 4.0);
}

TEST(CoverageTest, RepeatedStatesCountOnce) {
  const Eigen::MatrixXd visited = Eigen::MatrixXd::Constant(100, 1, 0.5);
  const Coverage coverage = *ComputeCoverage(visited, MakeBox({0.0}, {1.0}), 10, 5);
  EXPECT_DOUBLE_EQ(coverage.marginal, 0.1);
  EXPECT_DOUBLE_EQ(*coverage.joint, 0.2);
}

TEST(CoverageTest, NoJointAboveFourDimensions) {
  const Eigen::MatrixXd visited = Eigen::MatrixXd::Zero(3, 5);
  const Box region{Eigen::VectorXd::Constant(5, -1.0), Eigen::VectorXd::Constant(5, 1.0)};
  const Coverage coverage = *ComputeCoverage(visited, region, 2, 10);
  EXPECT_DOUBLE_EQ(coverage.marginal, 0.5);
  EXPECT_FALSE(coverage.joint.has_value());
}

TEST(CoverageTest, JointUpToFourDimensions) {
  const Eigen::MatrixXd visited = Eigen::MatrixXd::Zero(1, 4);
  const Box region{Eigen::VectorXd::Constant(4, -1.0), Eigen::VectorXd::Constant(4, 1.0)};
  const Coverage coverage = *ComputeCoverage(visited, region, 2, 10);
  ASSERT_TRUE(coverage.joint.has_value());
  EXPECT_DOUBLE_EQ(*coverage.joint, 1e-4);
}

TEST(CoverageTest, Errors) {
  const Eigen::MatrixXd visited = Eigen::MatrixXd::Zero(3, 2);
  const Box region = MakeBox({0.0, 0.0}, {1.0, 1.0});
  EXPECT_EQ(ComputeCoverage(visited, region, 0, 2).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ComputeCoverage(visited, region, 2, 0).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ComputeCoverage(visited, MakeBox({0.0}, {1.0}), 2, 2).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(
      ComputeCoverage(visited, MakeBox({0.0, 1.0}, {1.0, 1.0}), 2, 2).status().code(),
      absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace excite::sim
