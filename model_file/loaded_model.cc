#include "model_file/loaded_model.h"

#include <cmath>
#include <fstream>
#include <iterator>
#include <utility>

#include "Eigen/Dense"
#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "model_file/model_file.h"

namespace excite {
namespace {

// z's features: each angle as its (sin, cos) pair, in place.
Eigen::MatrixXd Features(const model::ModelData& data, const Eigen::MatrixXd& z) {
  const Eigen::Index features = data.feature_center.size();
  Eigen::MatrixXd out(z.rows(), features);
  Eigen::Index f = 0;
  for (Eigen::Index i = 0; i < z.cols(); ++i) {
    bool angle = false;
    for (int a : data.angle_dims) angle = angle || a == i;
    if (angle) {
      out.col(f++) = z.col(i).array().sin().matrix();
      out.col(f++) = z.col(i).array().cos().matrix();
    } else {
      out.col(f++) = z.col(i);
    }
  }
  return out;
}

}  // namespace

absl::StatusOr<LoadedModel> LoadedModel::Load(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  if (!file)
    return absl::NotFoundError(absl::StrCat("cannot open the model file ", path));
  const std::string bytes((std::istreambuf_iterator<char>(file)),
                          std::istreambuf_iterator<char>());
  absl::StatusOr<LoadedModel> model = FromBytes(bytes);
  if (!model.ok()) {
    return absl::Status(model.status().code(),
                        absl::StrCat(path, ": ", model.status().message()));
  }
  return model;
}

absl::StatusOr<LoadedModel> LoadedModel::FromBytes(absl::string_view bytes) {
  absl::StatusOr<model::ModelData> data = model::DecodeModelFile(bytes);
  if (!data.ok()) return data.status();
  return LoadedModel(*std::move(data));
}

absl::Status LoadedModel::Predict(const Eigen::MatrixXd& z, Eigen::MatrixXd* mean,
                                  Eigen::MatrixXd* variance, bool include_noise) const {
  const model::ModelData& d = data_;
  if (z.cols() != d.state_dim + d.input_dim) {
    return absl::InvalidArgumentError(absl::StrCat(
        "z has ", z.cols(),
        " columns; the model takes state_dim + input_dim = ", d.state_dim + d.input_dim));
  }
  const Eigen::MatrixXd normalised =
      (Features(d, z).rowwise() - d.feature_center.transpose()) *
      d.feature_half_width.cwiseInverse().asDiagonal();
  if (mean != nullptr) mean->resize(z.rows(), d.state_dim);
  if (variance != nullptr) variance->resize(z.rows(), d.state_dim);
  // The prior mean at each query (queries x state_dim).
  Eigen::MatrixXd prior = Eigen::MatrixXd::Zero(z.rows(), d.state_dim);
  if (d.prior_slopes.size() > 0) prior = normalised * d.prior_slopes.transpose();
  prior.rowwise() += d.prior_mean.transpose();
  if (mean != nullptr && d.delta) prior += z.leftCols(d.state_dim);
  for (int j = 0; j < d.state_dim; ++j) {
    const model::OutputData& o = d.outputs[static_cast<size_t>(j)];
    const double scale = d.output_std(j);
    if (o.points.rows() == 0) {  // a sparse GP without inducing points: its prior
      if (mean != nullptr) mean->col(j) = prior.col(j);
      if (variance != nullptr) {
        variance->col(j).setConstant(scale * scale * o.signal_variance +
                                     (include_noise ? d.noise_variance(j) : 0.0));
      }
      continue;
    }
    const Eigen::MatrixXd a = normalised * o.lengthscales.cwiseInverse().asDiagonal();
    const Eigen::MatrixXd p = o.points * o.lengthscales.cwiseInverse().asDiagonal();
    Eigen::MatrixXd k(p.rows(), a.rows());  // points x queries
    for (Eigen::Index q = 0; q < a.rows(); ++q) {
      k.col(q) = (o.signal_variance *
                  (-0.5 * (p.rowwise() - a.row(q)).rowwise().squaredNorm()).array().exp())
                     .matrix();
    }
    if (mean != nullptr)
      mean->col(j) = prior.col(j) + scale * (k.transpose() * o.weights);
    if (variance != nullptr) {
      const Eigen::MatrixXd v1 = o.factor.triangularView<Eigen::Lower>().solve(k);
      Eigen::ArrayXd latent =
          o.signal_variance - v1.colwise().squaredNorm().transpose().array();
      if (o.sparse_factor.size() > 0) {
        const Eigen::MatrixXd v2 =
            o.sparse_factor.triangularView<Eigen::Lower>().solve(v1);
        latent += v2.colwise().squaredNorm().transpose().array();
      }
      variance->col(j) = (scale * scale * latent.cwiseMax(0.0)).matrix();
      if (include_noise) variance->col(j).array() += d.noise_variance(j);
    }
  }
  return absl::OkStatus();
}

}  // namespace excite
