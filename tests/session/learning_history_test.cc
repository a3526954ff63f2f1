#include "server/session/learning_history.h"

#include <cmath>
#include <vector>

#include "common/angles.h"
#include "gtest/gtest.h"

namespace excite::session {
namespace {

// x' ~ N(mean, variance) with mean = z A (2 states, 1 input) and the latent
// variance of output j = (j + 1) (1 + z_0^2): closed forms to check against.
class LinearPredictor : public gp::DynamicsPredictor {
 public:
  int state_dim() const override { return 2; }
  int input_dim() const override { return 1; }
  void Predict(const Eigen::MatrixXd& z, Eigen::MatrixXd* mean, Eigen::MatrixXd* variance,
               std::vector<Eigen::MatrixXd>* /*mean_jacobians*/,
               std::vector<Eigen::MatrixXd>* /*variance_jacobians*/) const override {
    Eigen::MatrixXd a(3, 2);
    a << 1.0, 0.1, 0.2, 0.9, 0.0, 0.5;
    if (mean != nullptr) *mean = z * a;
    if (variance != nullptr) {
      variance->resize(z.rows(), 2);
      for (Eigen::Index i = 0; i < z.rows(); ++i) {
        for (int j = 0; j < 2; ++j)
          (*variance)(i, j) = (j + 1) * (1.0 + z(i, 0) * z(i, 0));
      }
    }
  }
};

TEST(OneStepRmseTest, IsTheRootMeanSquareOfTheErrorsPerDimension) {
  const LinearPredictor model;
  Eigen::MatrixXd states(3, 2), inputs(3, 1);
  states << 0.1, 0.2, -0.3, 0.4, 1.0, -1.0;
  inputs << 0.5, -0.5, 2.0;
  Eigen::MatrixXd mean;
  Eigen::MatrixXd z(3, 3);
  z << states, inputs;
  model.Predict(z, &mean, nullptr, nullptr, nullptr);
  Eigen::MatrixXd errors(3, 2);
  errors << 0.1, -0.2, 0.3, 0.0, -0.2, 0.4;
  const Eigen::VectorXd rmse = OneStepRmse(model, states, inputs, mean + errors, {});
  EXPECT_NEAR(rmse(0), std::sqrt((0.01 + 0.09 + 0.04) / 3), 1e-14);
  EXPECT_NEAR(rmse(1), std::sqrt((0.04 + 0.0 + 0.16) / 3), 1e-14);
}

TEST(OneStepRmseTest, ComparesAnglesTheShorterWayRound) {
  const LinearPredictor model;
  Eigen::MatrixXd states(2, 2), inputs(2, 1);
  states << 0.1, 0.2, -0.3, 0.4;
  inputs << 0.5, -0.5;
  Eigen::MatrixXd z(2, 3);
  z << states, inputs;
  Eigen::MatrixXd next;
  model.Predict(z, &next, nullptr, nullptr, nullptr);
  // Dimension 0 lands whole turns away from the prediction, plus 0.1 / -0.3.
  next(0, 0) += 2 * kPi + 0.1;
  next(1, 0) += -6 * kPi - 0.3;
  const Eigen::VectorXd as_angle = OneStepRmse(model, states, inputs, next, {0});
  EXPECT_NEAR(as_angle(0), std::sqrt((0.01 + 0.09) / 2), 1e-12);
  EXPECT_NEAR(as_angle(1), 0.0, 1e-14);
  const Eigen::VectorXd as_line = OneStepRmse(model, states, inputs, next, {});
  EXPECT_GT(as_line(0), 10.0);
}

TEST(MeanPredictiveStdTest, AveragesTheStandardDeviationOverTheReferenceSet) {
  const LinearPredictor model;
  Eigen::MatrixXd reference(4, 3);
  reference << 0.0, 1, 2, 1.0, 0, 0, -2.0, 3, 1, 0.5, 0, 0;
  const Eigen::VectorXd mean_std = MeanPredictiveStd(model, reference);
  double expected = 0.0;
  for (double z0 : {0.0, 1.0, -2.0, 0.5}) expected += std::sqrt(1.0 + z0 * z0) / 4;
  EXPECT_NEAR(mean_std(0), expected, 1e-14);
  EXPECT_NEAR(mean_std(1), std::sqrt(2.0) * expected, 1e-14);
}

PlanRecord PlanAt(int64_t sample_count) {
  PlanRecord record;
  record.sample_count = sample_count;
  return record;
}

TEST(LearningHistoryTest, AFullSeriesDropsEverySecondRecordAndKeepsItsSpan) {
  LearningHistory history(8);
  for (int64_t i = 0; i < 8; ++i) history.Add(PlanAt(i));
  ASSERT_EQ(history.plans().size(), 8u);
  history.Add(PlanAt(8));
  std::vector<int64_t> kept;
  for (const PlanRecord& r : history.plans()) kept.push_back(r.sample_count);
  EXPECT_EQ(kept, (std::vector<int64_t>{0, 2, 4, 6, 8}));
  for (int64_t i = 9; i < 1000; ++i) history.Add(PlanAt(i));
  EXPECT_LE(history.plans().size(), 8u);
  EXPECT_EQ(history.plans().front().sample_count, 0);
  EXPECT_EQ(history.plans().back().sample_count, 999);
  EXPECT_TRUE(history.batch_errors().empty());  // series are independent
}

TEST(LearningHistoryTest, UncertaintyIsDueAfterTwoPercentGrowth) {
  LearningHistory history;
  EXPECT_TRUE(history.UncertaintyDue(0));
  history.Add(UncertaintyRecord{10, 1, Eigen::VectorXd::Ones(2)});
  EXPECT_FALSE(history.UncertaintyDue(10));
  EXPECT_TRUE(history.UncertaintyDue(11));  // at least one sample
  history.Add(UncertaintyRecord{100, 2, Eigen::VectorXd::Ones(2)});
  EXPECT_FALSE(history.UncertaintyDue(101));
  EXPECT_TRUE(history.UncertaintyDue(102));
}

}  // namespace
}  // namespace excite::session
