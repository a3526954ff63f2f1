#include "server/plan/rollout.h"

#include "server/plan/entropy_objective.h"

namespace excite::plan {

Rollout RollOut(const gp::DynamicsPredictor& model, const Eigen::VectorXd& x0,
                const Eigen::MatrixXd& inputs, const Hallucination* hallucination) {
  const int horizon = static_cast<int>(inputs.rows());
  const int dx = model.state_dim();
  const int du = model.input_dim();
  Rollout r;
  r.inputs = inputs;
  r.states.resize(horizon, dx);
  r.means.resize(horizon, dx);
  r.variances.resize(horizon, dx);
  if (x0.size() != dx || inputs.cols() != du) return r;
  if (hallucination != nullptr && hallucination->eta.rows() > 0 &&
      hallucination->eta.cols() != dx) {
    return r;
  }
  // The means chain from step to step, so they are one-point calls; they need no
  // triangular solve (k^T alpha). The variances then come from one batched call
  // (one BLAS-3 solve instead of M BLAS-2 ones), unless the hallucination needs
  // each variance to find the next state.
  const bool hallucinate = hallucination != nullptr && hallucination->eta.rows() > 0;
  Eigen::MatrixXd z(1, dx + du);
  Eigen::MatrixXd mean;
  Eigen::MatrixXd variance;
  Eigen::VectorXd x = x0;
  for (int i = 0; i < horizon; ++i) {
    r.states.row(i) = x.transpose();
    z.row(0).head(dx) = x.transpose();
    z.row(0).tail(du) = inputs.row(i);
    model.Predict(z, &mean, hallucinate ? &variance : nullptr, nullptr, nullptr);
    if (mean.rows() != 1 || mean.cols() != dx ||
        (hallucinate && (variance.rows() != 1 || variance.cols() != dx))) {
      return r;
    }
    r.means.row(i) = mean.row(0);
    x = mean.row(0).transpose();
    if (hallucinate) {
      r.variances.row(i) = variance.row(0);
      if (i < hallucination->eta.rows()) {
        x += hallucination->beta *
             variance.row(0)
                 .transpose()
                 .cwiseMax(kVarianceFloor)
                 .cwiseSqrt()
                 .cwiseProduct(hallucination->eta.row(i).transpose());
      }
    }
  }
  if (!hallucinate && horizon > 0) {
    model.Predict(PointsOf(r), nullptr, &variance, nullptr, nullptr);
    if (variance.rows() != horizon || variance.cols() != dx) return r;
    r.variances = variance;
  }
  r.valid = r.states.allFinite() && r.means.allFinite() && r.variances.allFinite();
  return r;
}

Eigen::MatrixXd PointsOf(const Rollout& rollout) {
  Eigen::MatrixXd z(rollout.inputs.rows(), rollout.states.cols() + rollout.inputs.cols());
  z << rollout.states, rollout.inputs;
  return z;
}

}  // namespace excite::plan
