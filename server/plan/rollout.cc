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

PropagatedTrajectory PropagateLinearised(const gp::DynamicsPredictor& model,
                                         const Eigen::VectorXd& x0,
                                         const Eigen::MatrixXd& x0_covariance,
                                         const Eigen::MatrixXd& inputs,
                                         const Eigen::VectorXd& step_noise) {
  const int dx = model.state_dim();
  const int du = model.input_dim();
  const auto steps = inputs.rows();
  PropagatedTrajectory out;
  if (x0.size() != dx || x0_covariance.rows() != dx || x0_covariance.cols() != dx ||
      inputs.cols() != du || (step_noise.size() != 0 && step_noise.size() != dx)) {
    return out;
  }
  out.means.resize(steps + 1, dx);
  out.means.row(0) = x0.transpose();
  out.covariances.assign(static_cast<size_t>(steps + 1), x0_covariance);
  Eigen::MatrixXd z(1, dx + du);
  Eigen::MatrixXd mean;
  Eigen::MatrixXd variance;
  std::vector<Eigen::MatrixXd> jacobians;
  for (Eigen::Index k = 0; k < steps; ++k) {
    z << out.means.row(k), inputs.row(k);
    model.Predict(z, &mean, &variance, &jacobians, nullptr);
    const Eigen::MatrixXd a = jacobians[0].leftCols(dx);
    Eigen::VectorXd added = variance.row(0).transpose().cwiseMax(0.0);
    if (step_noise.size() == dx) added += step_noise;
    out.means.row(k + 1) = mean.row(0);
    Eigen::MatrixXd next = a * out.covariances[static_cast<size_t>(k)] * a.transpose();
    next.diagonal() += added;
    out.covariances[static_cast<size_t>(k + 1)] = 0.5 * (next + next.transpose());
  }
  out.valid = out.means.allFinite();
  for (const Eigen::MatrixXd& c : out.covariances) out.valid = out.valid && c.allFinite();
  return out;
}

Eigen::MatrixXd PointsOf(const Rollout& rollout) {
  Eigen::MatrixXd z(rollout.inputs.rows(), rollout.states.cols() + rollout.inputs.cols());
  z << rollout.states, rollout.inputs;
  return z;
}

}  // namespace excite::plan
