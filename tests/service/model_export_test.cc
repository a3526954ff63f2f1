// ExportModel on every system's config (sim/configs), exact and sparse: the
// model file, read by LoadedModel without a server, predicts what the server's
// Predict answers, to 1e-9.

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "client/excite_client.h"
#include "gtest/gtest.h"
#include "model_file/loaded_model.h"
#include "model_file/model_file.h"
#include "sim/evaluation.h"
#include "sim/plants/plant_factory.h"
#include "sim/sim_config.h"
#include "tests/service/service_fixture.h"

namespace excite::service {
namespace {

using ModelExportTest = ::excite::testing::ServiceTest;

// The plant's own transitions from `points` states and inputs drawn uniformly
// over the session's region (seeded).
sim::EvaluationSet Draw(const sim::Plant& plant, const v1::SessionConfig& session,
                        int points, uint64_t seed) {
  absl::StatusOr<sim::EvaluationSet> set =
      sim::MakeEvaluationSet(plant, sim::BoxOf(session.state_bounds()),
                             sim::BoxOf(session.input_bounds()), points, seed);
  EXPECT_TRUE(set.ok()) << set.status();
  return set.ok() ? *std::move(set) : sim::EvaluationSet();
}

TEST_F(ModelExportTest, TheFilePredictsWhatTheServerPredictsOnEverySystem) {
  std::vector<std::string> configs;
  for (const auto& entry : std::filesystem::directory_iterator(EXCITE_SIM_CONFIG_DIR)) {
    if (entry.path().extension() == ".textproto") configs.push_back(entry.path());
  }
  ASSERT_GE(configs.size(), 8u);
  for (const std::string& path : configs) {
    for (bool sparse : {false, true}) {
      // Linear prior mean on the sparse model: every path once per system.
      const bool linear = sparse;
      SCOPED_TRACE(path + (sparse ? " sparse, linear mean" : " exact"));
      absl::StatusOr<v1::SimConfig> sim_config = sim::LoadSimConfig(path);
      ASSERT_TRUE(sim_config.ok()) << sim_config.status();
      absl::StatusOr<std::unique_ptr<sim::Plant>> plant =
          sim::MakePlant(sim_config->plant());
      ASSERT_TRUE(plant.ok()) << plant.status();
      v1::SessionConfig config = sim_config->session();
      if (sparse) {
        config.mutable_sparse()->set_above_samples(20);
        config.mutable_sparse()->set_max_inducing(12);
      }
      if (linear) config.set_prior_mean(v1::PRIOR_MEAN_LINEAR);
      const int dx = config.state_dim();
      std::string id = std::string(sparse ? "sparse-" : "exact-") +
                       std::filesystem::path(path).stem().string();
      std::replace(id.begin(), id.end(), '_', '-');
      const std::string name = Create(id, config).name();
      // Linear: more samples than 2 (features + 1) on every system, so it is fitted.
      const int n = linear ? 56 : 40;
      const sim::EvaluationSet data = Draw(**plant, config, n, 1);
      std::vector<v1::Transition> batch;
      for (Eigen::Index i = 0; i < data.inputs.rows(); ++i) {
        v1::Transition t;
        for (int d = 0; d < dx; ++d) t.add_state(data.inputs(i, d));
        for (Eigen::Index d = dx; d < data.inputs.cols(); ++d)
          t.add_input(data.inputs(i, d));
        for (int d = 0; d < dx; ++d) t.add_next_state(data.next_states(i, d));
        t.set_sequence(i);
        batch.push_back(std::move(t));
      }
      Add(name, {batch});

      absl::StatusOr<v1::ExportModelResponse> exported = client_->ExportModel(name);
      ASSERT_TRUE(exported.ok()) << exported.status();
      EXPECT_EQ(exported->format_version(), linear ? 2u : 1u);
      EXPECT_EQ(exported->sample_count(), n);
      absl::StatusOr<LoadedModel> loaded = LoadedModel::FromBytes(exported->model_file());
      ASSERT_TRUE(loaded.ok()) << loaded.status();
      EXPECT_EQ(loaded->data().model_version, exported->model_version());
      EXPECT_EQ(loaded->data().prior_slopes.isZero(0.0), !linear);
      // Exact: every sample is a point; sparse: the inducing points only (none for
      // an output whose fitted signal is too weak to need one: its prior).
      for (const model::OutputData& o : loaded->data().outputs) {
        EXPECT_EQ(o.points.rows() == n, !sparse) << o.points.rows();
      }

      const sim::EvaluationSet queries = Draw(**plant, config, 30, 2);
      for (bool include_noise : {false, true}) {
        v1::PredictRequest request;
        request.set_session(name);
        request.set_include_noise(include_noise);
        for (Eigen::Index i = 0; i < queries.inputs.rows(); ++i) {
          for (Eigen::Index d = 0; d < queries.inputs.cols(); ++d) {
            request.add_inputs(queries.inputs(i, d));
          }
        }
        absl::StatusOr<v1::PredictResponse> served = client_->Predict(request);
        ASSERT_TRUE(served.ok()) << served.status();
        Eigen::MatrixXd mean, variance;
        ASSERT_TRUE(
            loaded->Predict(queries.inputs, &mean, &variance, include_noise).ok());
        for (Eigen::Index i = 0; i < mean.rows(); ++i) {
          for (int d = 0; d < dx; ++d) {
            const double m = served->mean(static_cast<int>(i * dx + d));
            const double v = served->variance(static_cast<int>(i * dx + d));
            EXPECT_NEAR(mean(i, d), m, 1e-9 * std::abs(m) + 1e-15) << i << ", " << d;
            // Plus 1e-10 of the prior variance: a variance that cancellation drove
            // near 0 has an absolute rounding error of a few eps of it.
            const model::ModelData& m_data = loaded->data();
            const double floor = 1e-10 * m_data.output_std(d) * m_data.output_std(d) *
                                 m_data.outputs[static_cast<size_t>(d)].signal_variance;
            EXPECT_NEAR(variance(i, d), v, 1e-9 * std::abs(v) + floor + 1e-15)
                << i << ", " << d;
          }
        }
      }
      ASSERT_TRUE(client_->DeleteSession(name).ok());
    }
  }
}

TEST_F(ModelExportTest, NeedsDataAndAKnownSession) {
  const std::string name = Create("empty").name();
  EXPECT_EQ(client_->ExportModel(name).status().code(),
            absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(client_->ExportModel("sessions/nope").status().code(),
            absl::StatusCode::kNotFound);
  EXPECT_EQ(client_->ExportModel("nope/x").status().code(),
            absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace excite::service
