#ifndef EXCITE_SERVER_GP_INPUT_FEATURES_H_
#define EXCITE_SERVER_GP_INPUT_FEATURES_H_

#include <Eigen/Dense>
#include <vector>

namespace excite::gp {

// What the GPs see of a model input z = (x, u): z itself, except that each
// angle (a state dimension on the circle) becomes the pair (sin, cos), so a
// state and the same state plus 2 pi are one point. The pair has a lengthscale
// each (a squared-exponential kernel on (sin, cos) with equal lengthscales is
// the periodic kernel; separate ones let the fit stretch it). Features keep
// z's order, an angle's pair where the angle was.
class InputFeatures {
 public:
  // angles: indices into z (state dimensions), each once, in [0, z_dim); the
  // caller checks them.
  InputFeatures(int z_dim, std::vector<int> angles);

  int z_dim() const { return z_dim_; }
  int feature_dim() const { return z_dim_ + static_cast<int>(angles_.size()); }
  const std::vector<int>& angles() const { return angles_; }
  bool is_angle(int z_index) const {
    return first_feature_[z_index + 1] - first_feature_[z_index] == 2;
  }

  // m x z_dim to m x feature_dim.
  Eigen::MatrixXd Map(const Eigen::MatrixXd& z) const;
  // Normalisation of the features from that of z (z_dim entries each): an
  // angle's sine and cosine are centred on 0 with half-width 1.
  Eigen::VectorXd MapCenter(const Eigen::VectorXd& z_center) const;
  Eigen::VectorXd MapHalfWidth(const Eigen::VectorXd& z_half_width) const;
  // Chain rule: rows of derivatives w.r.t. the features of the point z_row
  // (k x feature_dim) to derivatives w.r.t. z (k x z_dim).
  Eigen::MatrixXd PullBack(const Eigen::MatrixXd& d_features,
                           const Eigen::RowVectorXd& z_row) const;

 private:
  // One value per input to one per feature: an angle's two get `angle_value`.
  Eigen::VectorXd PerFeature(const Eigen::VectorXd& per_input, double angle_value) const;

  int z_dim_;
  std::vector<int> angles_;
  // first_feature_[i]: the feature of z's column i (z_dim + 1 entries, the last
  // is feature_dim()).
  std::vector<int> first_feature_;
};

}  // namespace excite::gp

#endif  // EXCITE_SERVER_GP_INPUT_FEATURES_H_
