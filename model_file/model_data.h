#ifndef EXCITE_MODEL_FILE_MODEL_DATA_H_
#define EXCITE_MODEL_FILE_MODEL_DATA_H_

#include <cstdint>
#include <vector>

#include "Eigen/Core"

namespace excite::model {

// One output's GP as its predictions need it, in the model's normalised units
// (features centred and divided by their half-widths, targets divided by the
// output's std). With a the normalised features of a point, l the lengthscales
// and k_i = signal_variance exp(-|(a - points_i) / l|^2 / 2):
//   mean = k . weights
//   variance = signal_variance - |factor \ k|^2 + |sparse_factor \ (factor \ k)|^2
// (the last term only for a sparse GP; variance clamped at 0). For an exact GP,
// points are the training inputs, weights K^-1 y and factor chol(K + noise I);
// for a sparse one, the inducing points, their weights, chol(Kzz) and chol(B).
struct OutputData {
  double signal_variance = 0.0;
  Eigen::VectorXd lengthscales;   // one per feature
  Eigen::MatrixXd points;         // m x features
  Eigen::VectorXd weights;        // m
  Eigen::MatrixXd factor;         // m x m, lower triangular
  Eigen::MatrixXd sparse_factor;  // m x m lower triangular, or 0 x 0 (exact GP)
};

// What a fitted dynamics model's Predict depends on (gp::DynamicsModel::
// ExportModel), self-contained: a reader maps z = (x, u) to features (each
// angle of angle_dims to its (sin, cos) pair, in place; the rest as they are),
// normalises them, and per state dimension j predicts
//   mean_j = prior_mean_j + prior_slopes_j . a + output_std_j * (k . weights)
//            [+ x_j if delta]
// (a: the normalised features; prior_slopes are 0 for a constant prior mean)
//   variance_j = output_std_j^2 * latent variance [+ noise_variance_j for a
//   measured rather than a true next state].
struct ModelData {
  int state_dim = 0;
  int input_dim = 0;
  bool delta = true;  // the GPs model x_next - x (else x_next itself)
  std::vector<int> angle_dims;
  Eigen::VectorXd feature_center;      // one per feature
  Eigen::VectorXd feature_half_width;  // one per feature
  Eigen::VectorXd prior_mean;          // state_dim, data units
  Eigen::MatrixXd prior_slopes;        // state_dim x features (see above)
  Eigen::VectorXd output_std;          // state_dim
  Eigen::VectorXd noise_variance;      // state_dim, data units
  std::vector<OutputData> outputs;     // state_dim
  int64_t sample_count = 0;            // the samples the model was fitted on
  int64_t model_version = 0;           // the session's, when known (else 0)
};

}  // namespace excite::model

#endif  // EXCITE_MODEL_FILE_MODEL_DATA_H_
