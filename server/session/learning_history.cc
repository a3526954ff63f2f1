#include "server/session/learning_history.h"

#include <algorithm>
#include <cmath>

#include "common/angles.h"

namespace excite::session {

LearningHistory::LearningHistory(size_t capacity)
    : capacity_(std::max<size_t>(2, capacity)) {}

bool LearningHistory::UncertaintyDue(int64_t sample_count) const {
  if (uncertainty_.empty()) return true;
  const int64_t last = uncertainty_.back().sample_count;
  const auto step = std::max<int64_t>(1, static_cast<int64_t>(std::ceil(0.02 * last)));
  return sample_count >= last + step;
}

Eigen::VectorXd OneStepRmse(const gp::DynamicsPredictor& model,
                            const Eigen::MatrixXd& states, const Eigen::MatrixXd& inputs,
                            const Eigen::MatrixXd& next_states,
                            const std::vector<int>& angle_dims) {
  Eigen::MatrixXd z(states.rows(), states.cols() + inputs.cols());
  z << states, inputs;
  Eigen::MatrixXd mean;
  model.Predict(z, &mean, nullptr, nullptr, nullptr);
  Eigen::MatrixXd error = next_states - mean;
  for (const int d : angle_dims) error.col(d) = error.col(d).unaryExpr(&WrapAngle);
  return (error.array().square().colwise().mean()).sqrt().transpose();
}

Eigen::VectorXd MeanPredictiveStd(const gp::DynamicsPredictor& model,
                                  const Eigen::MatrixXd& reference) {
  Eigen::MatrixXd mean;
  Eigen::MatrixXd variance;
  model.Predict(reference, &mean, &variance, nullptr, nullptr);
  return variance.array().max(0.0).sqrt().colwise().mean().transpose();
}

}  // namespace excite::session
