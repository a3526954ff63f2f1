#include "server/gp/input_features.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace excite::gp {

InputFeatures::InputFeatures(int z_dim, std::vector<int> angles)
    : z_dim_(z_dim), angles_(std::move(angles)) {
  std::sort(angles_.begin(), angles_.end());
  first_feature_.resize(z_dim_ + 1);
  int f = 0;
  for (int i = 0; i < z_dim_; ++i) {
    first_feature_[i] = f;
    f += std::binary_search(angles_.begin(), angles_.end(), i) ? 2 : 1;
  }
  first_feature_[z_dim_] = f;
}

Eigen::MatrixXd InputFeatures::Map(const Eigen::MatrixXd& z) const {
  if (angles_.empty()) return z;
  Eigen::MatrixXd out(z.rows(), feature_dim());
  for (int i = 0; i < z_dim_; ++i) {
    const int f = first_feature_[i];
    if (is_angle(i)) {
      out.col(f) = z.col(i).array().sin().matrix();
      out.col(f + 1) = z.col(i).array().cos().matrix();
    } else {
      out.col(f) = z.col(i);
    }
  }
  return out;
}

Eigen::VectorXd InputFeatures::PerFeature(const Eigen::VectorXd& per_input,
                                          double angle_value) const {
  if (angles_.empty()) return per_input;
  Eigen::VectorXd out(feature_dim());
  for (int i = 0; i < z_dim_; ++i) {
    const int f = first_feature_[i];
    if (is_angle(i)) {
      out.segment(f, 2).setConstant(angle_value);
    } else {
      out(f) = per_input(i);
    }
  }
  return out;
}

Eigen::VectorXd InputFeatures::MapCenter(const Eigen::VectorXd& z_center) const {
  return PerFeature(z_center, 0.0);
}

Eigen::VectorXd InputFeatures::MapHalfWidth(const Eigen::VectorXd& z_half_width) const {
  return PerFeature(z_half_width, 1.0);
}

Eigen::MatrixXd InputFeatures::PullBack(const Eigen::MatrixXd& d_features,
                                        const Eigen::RowVectorXd& z_row) const {
  if (angles_.empty()) return d_features;
  Eigen::MatrixXd out(d_features.rows(), z_dim_);
  for (int i = 0; i < z_dim_; ++i) {
    const int f = first_feature_[i];
    if (is_angle(i)) {
      // d sin / d theta = cos, d cos / d theta = -sin.
      out.col(i) = std::cos(z_row(i)) * d_features.col(f) -
                   std::sin(z_row(i)) * d_features.col(f + 1);
    } else {
      out.col(i) = d_features.col(f);
    }
  }
  return out;
}

}  // namespace excite::gp
