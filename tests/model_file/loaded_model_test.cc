// The model file and LoadedModel against the model they were exported from: a
// fitted gp::DynamicsModel (exact, sparse, with an angle, delta and next-state
// targets) predicts what LoadedModel predicts from its file, to 1e-9.

#include "model_file/loaded_model.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <fstream>
#include <string>

#include "model_file/model_file.h"
#include "server/gp/dynamics_model.h"
#include "tests/gp/pendulum_samples.h"
#include "tests/support/temp_dir.h"

namespace excite {
namespace {

struct Variant {
  const char* name;
  bool sparse;
  bool angle;
  gp::Target target;
  gp::PriorMean prior_mean = gp::PriorMean::kConstant;
};

gp::DynamicsModel Fitted(const Variant& v) {
  gp::DynamicsModelOptions o;
  o.state_dim = 2;
  o.input_dim = 1;
  o.target = v.target;
  o.prior_mean = v.prior_mean;
  o.measurement_noise_variance = 1e-3;
  o.input_center = Eigen::Vector3d(0.0, 0.0, 0.0);
  o.input_half_width = Eigen::Vector3d(3.0, 6.0, 2.0);
  if (v.angle) o.angle_dims = {0};
  if (v.sparse) {
    o.sparse_above = 20;
    o.sparse.max_inducing = 15;
  }
  absl::StatusOr<gp::DynamicsModel> model = gp::DynamicsModel::Create(o);
  EXPECT_TRUE(model.ok()) << model.status();
  const gp::testing::Transitions d = gp::testing::PendulumTransitions(60, 7, 1e-3);
  EXPECT_TRUE(model->AddSamples(d.x, d.u, d.next).ok());
  EXPECT_TRUE(model->Refit().ok());
  // Samples after the fit enter the GPs by update, not refactorisation.
  const gp::testing::Transitions more = gp::testing::PendulumTransitions(5, 8, 1e-3);
  EXPECT_TRUE(model->AddSamples(more.x, more.u, more.next).ok());
  return *std::move(model);
}

// Points inside and beyond the data (angles past pi included).
Eigen::MatrixXd Queries() {
  const gp::testing::Transitions q = gp::testing::PendulumTransitions(40, 99, 0.0, -5, 5);
  Eigen::MatrixXd z(40, 3);
  z << q.x, q.u;
  return z;
}

// 1e-9 relative; a variance that cancellation (prior variance minus what the
// data explain) has driven near 0 carries an absolute rounding error of a few
// eps times the prior variance, amplified by the conditioning of K, in any
// implementation (BLAS builds differ: 9e-14 seen on a fresh machine), so
// `floor` (per column) bounds the error from below.
void ExpectClose(const Eigen::MatrixXd& actual, const Eigen::MatrixXd& expected,
                 const char* what, const Eigen::VectorXd& floor) {
  ASSERT_EQ(actual.rows(), expected.rows());
  ASSERT_EQ(actual.cols(), expected.cols());
  for (Eigen::Index i = 0; i < expected.rows(); ++i) {
    for (Eigen::Index j = 0; j < expected.cols(); ++j) {
      EXPECT_NEAR(actual(i, j), expected(i, j),
                  1e-9 * std::abs(expected(i, j)) + floor(j) + 1e-15)
          << what << " (" << i << ", " << j << ")";
    }
  }
}

// 1e-10 of each output's prior variance in data units.
Eigen::VectorXd VarianceFloor(const model::ModelData& data) {
  Eigen::VectorXd floor(data.state_dim);
  for (int j = 0; j < data.state_dim; ++j) {
    floor(j) = 1e-10 * data.output_std(j) * data.output_std(j) *
               data.outputs[static_cast<size_t>(j)].signal_variance;
  }
  return floor;
}

TEST(LoadedModelTest, PredictsWhatTheExportedModelPredicts) {
  for (const Variant& v : {Variant{"exact delta", false, false, gp::Target::kDelta},
                           Variant{"exact angle", false, true, gp::Target::kDelta},
                           Variant{"exact next", false, false, gp::Target::kNext},
                           Variant{"sparse delta", true, false, gp::Target::kDelta},
                           Variant{"sparse angle", true, true, gp::Target::kDelta},
                           Variant{"exact linear angle", false, true, gp::Target::kDelta,
                                   gp::PriorMean::kLinear},
                           Variant{"exact linear next", false, false, gp::Target::kNext,
                                   gp::PriorMean::kLinear},
                           Variant{"sparse linear", true, false, gp::Target::kDelta,
                                   gp::PriorMean::kLinear}}) {
    SCOPED_TRACE(v.name);
    const gp::DynamicsModel model = Fitted(v);
    ASSERT_EQ(model.sparse(), v.sparse);
    std::optional<model::ModelData> data = model.ExportModel();
    ASSERT_TRUE(data.has_value());
    const std::string bytes = model::EncodeModelFile(*data);
    // A constant prior mean is written as version 1, which older readers read.
    const bool linear = v.prior_mean == gp::PriorMean::kLinear;
    EXPECT_EQ(static_cast<int>(bytes[8]), linear ? 2 : 1);
    absl::StatusOr<LoadedModel> loaded = LoadedModel::FromBytes(bytes);
    ASSERT_TRUE(loaded.ok()) << loaded.status();
    EXPECT_EQ(loaded->data().prior_slopes.isZero(0.0), !linear);
    EXPECT_EQ(loaded->data().sample_count, 65);
    if (v.sparse) {
      EXPECT_LT(loaded->data().outputs[0].points.rows(), 65);  // inducing points only
      EXPECT_EQ(loaded->data().outputs[0].sparse_factor.rows(),
                loaded->data().outputs[0].points.rows());
    }
    const Eigen::MatrixXd z = Queries();
    Eigen::MatrixXd mean, variance, loaded_mean, loaded_variance, noisy;
    model.Predict(z, &mean, &variance, nullptr, nullptr);
    ASSERT_TRUE(loaded->Predict(z, &loaded_mean, &loaded_variance).ok());
    const Eigen::VectorXd none = Eigen::VectorXd::Zero(2);
    const Eigen::VectorXd floor = VarianceFloor(loaded->data());
    ExpectClose(loaded_mean, mean, "mean", none);
    ExpectClose(loaded_variance, variance, "variance", floor);
    ASSERT_TRUE(loaded->Predict(z, nullptr, &noisy, /*include_noise=*/true).ok());
    ExpectClose(noisy, variance + model.noise_variances().transpose().replicate(40, 1),
                "variance with noise", floor);
  }
}

TEST(LoadedModelTest, FileRoundTripsEveryNumberExactly) {
  const gp::DynamicsModel model =
      Fitted({"sparse angle", true, true, gp::Target::kDelta, gp::PriorMean::kLinear});
  model::ModelData data = *model.ExportModel();
  ASSERT_FALSE(data.prior_slopes.isZero(0.0));
  data.model_version = 42;
  testing::TempDir dir;
  const std::string path = dir.path() + "/m.model";
  std::ofstream(path, std::ios::binary) << model::EncodeModelFile(data);
  absl::StatusOr<LoadedModel> loaded = LoadedModel::Load(path);
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  const model::ModelData& back = loaded->data();
  EXPECT_EQ(back.model_version, 42);
  EXPECT_EQ(back.angle_dims, data.angle_dims);
  EXPECT_EQ(back.feature_half_width, data.feature_half_width);
  EXPECT_EQ(back.noise_variance, data.noise_variance);
  EXPECT_EQ(back.prior_slopes, data.prior_slopes);
  for (size_t j = 0; j < data.outputs.size(); ++j) {
    EXPECT_EQ(back.outputs[j].points, data.outputs[j].points);
    EXPECT_EQ(back.outputs[j].factor, data.outputs[j].factor);
    EXPECT_EQ(back.outputs[j].sparse_factor, data.outputs[j].sparse_factor);
    EXPECT_EQ(back.outputs[j].signal_variance, data.outputs[j].signal_variance);
  }
}

TEST(LoadedModelTest, RefusesWhatIsNotAModelFileAndANewerVersion) {
  const gp::DynamicsModel model =
      Fitted({"exact delta", false, false, gp::Target::kDelta});
  const std::string good = model::EncodeModelFile(*model.ExportModel());
  std::string newer = good;
  newer[8] = static_cast<char>(model::kModelFileVersion + 1);  // the version's low byte
  absl::Status status = LoadedModel::FromBytes(newer).status();
  EXPECT_EQ(status.code(), absl::StatusCode::kFailedPrecondition) << status;
  EXPECT_NE(status.message().find("format version 3; this reader knows versions up to 2"),
            std::string::npos)
      << status;
  for (const std::string& bad :
       {std::string("EXCITEMX") + good.substr(8), good.substr(0, good.size() - 3),
        good + "x", good.substr(0, 12), std::string()}) {
    status = LoadedModel::FromBytes(bad).status();
    EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument) << status;
    EXPECT_NE(status.message().find("not an excite model file"), std::string::npos)
        << status;
  }
  EXPECT_EQ(LoadedModel::Load("/no/such/file").status().code(),
            absl::StatusCode::kNotFound);
  absl::StatusOr<LoadedModel> loaded = LoadedModel::FromBytes(good);
  ASSERT_TRUE(loaded.ok());
  Eigen::MatrixXd mean;
  EXPECT_EQ(loaded->Predict(Eigen::MatrixXd(2, 2), &mean, nullptr).code(),
            absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace excite
