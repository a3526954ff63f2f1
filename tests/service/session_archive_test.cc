// ExportSession / ImportSession over a real loopback server: round trips, the
// warm start, ALREADY_EXISTS, every validation rule of an archive (with its
// field path and nothing stored), caps, and persistence across a restart.

#include <cmath>
#include <functional>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "client/excite_client.h"
#include "google/protobuf/util/message_differencer.h"
#include "gtest/gtest.h"
#include "server/service/config_validation.h"
#include "tests/service/pendulum_data.h"
#include "tests/service/service_fixture.h"

namespace excite::testing {
namespace {

using ::google::protobuf::util::MessageDifferencer;

// Fixed hyperparameters of the pendulum config's two outputs.
v1::Hyperparameters PendulumHyperparameters(double signal_variance) {
  return excite::testing::PendulumHyperparameters(signal_variance, {1.5, 3.0, 2.0});
}

v1::SessionConfig FixedKernelConfig() {
  return PendulumFixedKernelConfig(PendulumHyperparameters(0.5),
                                   PendulumHyperparameters(40.0));
}

// A valid archive built by hand: 10 pendulum samples, hyperparameters for both
// outputs.
v1::SessionArchive ValidArchive(const std::string& id) {
  v1::SessionArchive archive = PendulumArchive(id);
  *archive.add_hyperparameters() = PendulumHyperparameters(0.5);
  *archive.add_hyperparameters() = PendulumHyperparameters(40.0);
  archive.set_created_unix_ms(1700000000000);
  return archive;
}

void ExpectSameMessage(const google::protobuf::Message& actual,
                       const google::protobuf::Message& expected) {
  MessageDifferencer differencer;
  std::string differences;
  differencer.ReportDifferencesToString(&differences);
  EXPECT_TRUE(differencer.Compare(actual, expected)) << differences;
}

v1::PredictRequest PredictAt(const std::string& name) {
  v1::PredictRequest predict;
  predict.set_session(name);
  for (double v : {0.3, -0.4, 1.0, -2.0, 3.5, -0.7}) predict.add_inputs(v);
  return predict;
}

class SessionArchiveTest : public ServiceTest {
 protected:
  v1::SessionArchive Export(const std::string& name) {
    absl::StatusOr<v1::SessionArchive> archive = client_->ExportSession(name);
    EXPECT_TRUE(archive.ok()) << archive.status();
    return archive.ok() ? *archive : v1::SessionArchive();
  }

  // ImportSession through the raw stub (to read the BadRequest details).
  grpc::Status RawImport(const v1::SessionArchive& archive, const std::string& id,
                         v1::Session* session) {
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
    v1::ImportSessionRequest request;
    *request.mutable_archive() = archive;
    request.set_session_id(id);
    return stub_->ImportSession(&context, request, session);
  }

  int SessionCount() {
    absl::StatusOr<v1::ListSessionsResponse> list = client_->ListSessions(0, "");
    EXPECT_TRUE(list.ok()) << list.status();
    return list.ok() ? list->sessions_size() : -1;
  }
};

// Create, add, fit once, export, delete, import: config, every sample and the
// hyperparameters come back exactly, and with hyperparameters that stay fixed
// (kernel.fit false, or refit.never) Predict gives the same mean as before.
TEST_F(SessionArchiveTest, RoundTripKeepsConfigSamplesHyperparametersAndPredictions) {
  v1::SessionConfig refit_never = PendulumConfig();
  refit_never.mutable_refit()->set_never(true);
  v1::SessionConfig angles = refit_never;  // four lengthscales: sin, cos, rate, torque
  angles.add_angle_dims(0);
  for (const auto& [id, config] : std::vector<std::pair<std::string, v1::SessionConfig>>{
           {"fixed-kernel", FixedKernelConfig()},
           {"refit-never", refit_never},
           {"angles", angles}}) {
    SCOPED_TRACE(id);
    const v1::Session created = Create(id, config);
    const std::vector<v1::Transition> first = PendulumTransitions(20, 0, 31);
    const std::vector<v1::Transition> second = PendulumTransitions(12, 20, 32);
    Add(created.name(), {first, second});
    // Plan once (the fit, with all the data): hyperparameters exist.
    ASSERT_TRUE(client_->PlanInputs(created.name(), {0.1, -0.2}).ok());
    const v1::Session before = *client_->GetSession(created.name());
    ASSERT_EQ(before.outputs_size(), 2);
    EXPECT_EQ(before.outputs(0).hyperparameters().lengthscales_size(),
              3 + config.angle_dims_size());
    absl::StatusOr<v1::PredictResponse> predicted_before =
        client_->Predict(PredictAt(created.name()));
    ASSERT_TRUE(predicted_before.ok()) << predicted_before.status();

    const v1::SessionArchive archive = Export(created.name());
    EXPECT_EQ(archive.format_version(), 1);
    EXPECT_EQ(archive.session_id(), id);
    ExpectSameMessage(archive.config(), created.config());
    ASSERT_EQ(archive.samples_size(), 32);
    for (int i = 0; i < 32; ++i) {
      ExpectSameMessage(archive.samples(i), i < 20 ? first[i] : second[i - 20]);
    }
    ASSERT_EQ(archive.hyperparameters_size(), 2);
    for (int i = 0; i < 2; ++i) {
      ExpectSameMessage(archive.hyperparameters(i), before.outputs(i).hyperparameters());
    }
    EXPECT_GT(archive.created_unix_ms(), 0);

    ASSERT_TRUE(client_->DeleteSession(created.name()).ok());
    ExpectStatus(client_->GetSession(created.name()).status(),
                 absl::StatusCode::kNotFound, "not found");

    absl::StatusOr<v1::Session> imported = client_->ImportSession(archive);
    ASSERT_TRUE(imported.ok()) << imported.status();
    EXPECT_EQ(imported->name(), created.name());
    ExpectSameMessage(imported->config(), created.config());
    EXPECT_EQ(imported->sample_count(), 32);
    EXPECT_EQ(imported->last_sequence(), 31);
    // Exported again before anything changed it: the same archive, creation
    // time included.
    ExpectSameMessage(Export(created.name()), archive);

    absl::StatusOr<v1::PredictResponse> predicted_after =
        client_->Predict(PredictAt(created.name()));
    ASSERT_TRUE(predicted_after.ok()) << predicted_after.status();
    ASSERT_EQ(predicted_after->mean_size(), predicted_before->mean_size());
    for (int i = 0; i < predicted_before->mean_size(); ++i) {
      EXPECT_NEAR(predicted_after->mean(i), predicted_before->mean(i), 1e-9) << i;
      EXPECT_NEAR(predicted_after->variance(i), predicted_before->variance(i), 1e-9) << i;
    }
    ExpectSameHyperparameters(*client_->GetSession(created.name()), before);
  }
}

// With angle_dims a state turned by 2 pi k predicts through the API as the
// state itself: the same variance and rate, the angle shifted by 2 pi k.
TEST_F(SessionArchiveTest, AnAngleTurnedByWholeTurnsPredictsTheSame) {
  v1::SessionConfig config = PendulumConfig();
  config.add_angle_dims(0);
  const std::string name = Create("angles", config).name();
  Add(name, {PendulumTransitions(30, 0, 51)});
  ASSERT_TRUE(client_->PlanInputs(name, {0.1, -0.2}).ok());
  const v1::PredictRequest request = PredictAt(name);
  v1::PredictRequest turned = request;
  turned.set_inputs(0, request.inputs(0) + 2 * M_PI);
  turned.set_inputs(3, request.inputs(3) - 6 * M_PI);
  absl::StatusOr<v1::PredictResponse> a = client_->Predict(request);
  absl::StatusOr<v1::PredictResponse> b = client_->Predict(turned);
  ASSERT_TRUE(a.ok() && b.ok()) << a.status() << b.status();
  ASSERT_EQ(a->mean_size(), 4);
  const double shift[4] = {2 * M_PI, 0.0, -6 * M_PI, 0.0};
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR(b->mean(i) - a->mean(i), shift[i], 1e-9) << i;
    // A posterior variance is the prior's (~1 here) minus what the data explain:
    // sin and cos of a turned angle differ in their last bits, and the
    // subtraction turns that into ~1e-15 absolute, which a small variance (~1e-6)
    // cannot meet relatively (it failed so on another CPU's BLAS kernels).
    EXPECT_NEAR(b->variance(i), a->variance(i), 1e-12 + 1e-9 * a->variance(i)) << i;
  }
}

// A refitting session imported under a new id reports the archived
// hyperparameters until its first refit, which starts from them.
TEST_F(SessionArchiveTest, ImportUnderANewIdSeedsTheWarmStart) {
  const std::string name = Create("warm").name();
  Add(name, {PendulumTransitions(25, 0, 41)});
  ASSERT_TRUE(client_->Predict(PredictAt(name)).ok());
  const v1::SessionArchive archive = Export(name);
  ASSERT_EQ(archive.hyperparameters_size(), 2);

  absl::StatusOr<v1::Session> copy = client_->ImportSession(archive, "warm-copy");
  ASSERT_TRUE(copy.ok()) << copy.status();
  EXPECT_EQ(copy->name(), "sessions/warm-copy");
  EXPECT_EQ(copy->sample_count(), 25);
  ASSERT_EQ(copy->outputs_size(), 2);  // before any refit
  for (int i = 0; i < 2; ++i) {
    ExpectSameMessage(copy->outputs(i).hyperparameters(), archive.hyperparameters(i));
  }
  EXPECT_EQ(client_->GetSession(name)->sample_count(), 25);  // the original stays
  // The copy's archive names the copy; the rest is the same.
  v1::SessionArchive copy_archive = Export("sessions/warm-copy");
  EXPECT_EQ(copy_archive.session_id(), "warm-copy");
  copy_archive.set_session_id("warm");
  ExpectSameMessage(copy_archive, archive);

  // The first refit starts there: with the same data it stays close.
  ASSERT_TRUE(client_->Predict(PredictAt("sessions/warm-copy")).ok());
  const v1::Session refitted = *client_->GetSession("sessions/warm-copy");
  ASSERT_EQ(refitted.outputs_size(), 2);
  for (int i = 0; i < 2; ++i) {
    EXPECT_NEAR(std::log(refitted.outputs(i).hyperparameters().signal_variance()),
                std::log(archive.hyperparameters(i).signal_variance()), 0.1);
  }
}

TEST_F(SessionArchiveTest, ImportIntoATakenIdIsAlreadyExistsAndChangesNothing) {
  const std::string name = Create("taken").name();
  Add(name, {PendulumTransitions(5, 0, 51)});
  const v1::SessionArchive before = Export(name);
  ExpectStatus(client_->ImportSession(ValidArchive("other"), "taken").status(),
               absl::StatusCode::kAlreadyExists, "sessions/taken already exists");
  ExpectStatus(client_->ImportSession(ValidArchive("taken")).status(),
               absl::StatusCode::kAlreadyExists, "sessions/taken already exists");
  ExpectSameMessage(Export(name), before);
  EXPECT_EQ(SessionCount(), 1);
}

TEST_F(SessionArchiveTest, ImportedSessionSurvivesARestart) {
  const v1::SessionArchive archive = ValidArchive("moved");
  ASSERT_TRUE(client_->ImportSession(archive).ok());
  const v1::SessionArchive exported = Export("sessions/moved");
  ExpectSameMessage(exported, archive);
  StopServer();
  StartServer();
  absl::StatusOr<v1::Session> restored = client_->GetSession("sessions/moved");
  ASSERT_TRUE(restored.ok()) << restored.status();
  EXPECT_EQ(restored->sample_count(), 10);
  EXPECT_EQ(restored->last_sequence(), 9);
  ExpectSameMessage(Export("sessions/moved"), archive);
  EXPECT_TRUE(client_->Predict(PredictAt("sessions/moved")).ok());
}

TEST_F(SessionArchiveTest, ExportOfAnUnknownOrMalformedNameFails) {
  ExpectStatus(client_->ExportSession("sessions/nope").status(),
               absl::StatusCode::kNotFound, "sessions/nope not found");
  ExpectStatus(client_->ExportSession("nope").status(),
               absl::StatusCode::kInvalidArgument, "name:");
  const std::string name = Create("gone").name();
  ASSERT_TRUE(client_->DeleteSession(name).ok());
  ExpectStatus(client_->ExportSession(name).status(), absl::StatusCode::kNotFound,
               "not found");
  // A session never fitted exports without hyperparameters.
  const std::string fresh = Create("fresh").name();
  Add(fresh, {PendulumTransitions(3, 0, 61)});
  const v1::SessionArchive archive = Export(fresh);
  EXPECT_EQ(archive.samples_size(), 3);
  EXPECT_EQ(archive.hyperparameters_size(), 0);
}

// Each rule: INVALID_ARGUMENT with a BadRequest naming the field, and nothing is
// stored (not even after a restart).
TEST_F(SessionArchiveTest, EachInvalidArchiveNamesItsFieldAndStoresNothing) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  struct Case {
    std::string field;
    std::function<void(v1::SessionArchive*)> mutate;
    std::string request_id = "";
  };
  const std::vector<Case> cases = {
      {"archive.format_version", [](v1::SessionArchive* a) { a->set_format_version(0); }},
      {"archive.format_version", [](v1::SessionArchive* a) { a->set_format_version(2); }},
      {"archive.session_id", [](v1::SessionArchive* a) { a->set_session_id("Bad_Id"); }},
      {"session_id", [](v1::SessionArchive*) {}, "no/slash"},
      {"archive.config.state_dim",
       [](v1::SessionArchive* a) { a->mutable_config()->set_state_dim(0); }},
      {"archive.config.input_bounds[0]",
       [](v1::SessionArchive* a) {
         a->mutable_config()->mutable_input_bounds(0)->set_lower(5);
       }},
      {"archive.samples[3].state",
       [](v1::SessionArchive* a) { a->mutable_samples(3)->add_state(0.0); }},
      {"archive.samples[1].input",
       [](v1::SessionArchive* a) { a->mutable_samples(1)->clear_input(); }},
      {"archive.samples[2].next_state[1]",
       [nan](v1::SessionArchive* a) { a->mutable_samples(2)->set_next_state(1, nan); }},
      {"archive.samples[6].input[0]",
       [inf](v1::SessionArchive* a) { a->mutable_samples(6)->set_input(0, inf); }},
      {"archive.samples[4].sequence",
       [](v1::SessionArchive* a) { a->mutable_samples(4)->set_sequence(-1); }},
      {"archive.samples[5].sequence",
       [](v1::SessionArchive* a) { a->mutable_samples(5)->set_sequence(2); }},
      {"archive.samples[0].timestamp_s",
       [nan](v1::SessionArchive* a) { a->mutable_samples(0)->set_timestamp_s(nan); }},
      {"archive.hyperparameters",
       [](v1::SessionArchive* a) { a->mutable_hyperparameters()->RemoveLast(); }},
      {"archive.hyperparameters[1].lengthscales",
       [](v1::SessionArchive* a) { a->mutable_hyperparameters(1)->add_lengthscales(1); }},
      {"archive.hyperparameters[0].lengthscales[2]",
       [](v1::SessionArchive* a) {
         a->mutable_hyperparameters(0)->set_lengthscales(2, 0);
       }},
      {"archive.hyperparameters[0].signal_variance",
       [](v1::SessionArchive* a) {
         a->mutable_hyperparameters(0)->set_signal_variance(-1);
       }},
      {"archive.hyperparameters[1].noise_variance",
       [nan](v1::SessionArchive* a) {
         a->mutable_hyperparameters(1)->set_noise_variance(nan);
       }},
      {"archive.fitted_sample_count",
       [](v1::SessionArchive* a) { a->set_fitted_sample_count(11); }},  // 10 samples
      {"archive.fitted_sample_count",
       [](v1::SessionArchive* a) { a->set_fitted_sample_count(-1); }},
      {"archive.fitted_sample_count",
       [](v1::SessionArchive* a) {
         a->clear_hyperparameters();
         a->set_fitted_sample_count(3);
       }},
      {"archive.created_unix_ms",
       [](v1::SessionArchive* a) { a->set_created_unix_ms(-5); }},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.field);
    v1::SessionArchive archive = ValidArchive("bad");
    c.mutate(&archive);
    v1::Session session;
    const grpc::Status status = RawImport(archive, c.request_id, &session);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT)
        << status.error_message();
    const google::rpc::BadRequest bad = BadRequestOf(status);
    ASSERT_EQ(bad.field_violations_size(), 1);
    EXPECT_EQ(bad.field_violations(0).field(), c.field);
    EXPECT_EQ(SessionCount(), 0);
  }
  StopServer();
  StartServer();
  EXPECT_EQ(SessionCount(), 0);
  // The unmodified archive is fine: each failure above was its mutation's.
  v1::Session session;
  const grpc::Status ok = RawImport(ValidArchive("bad"), "", &session);
  EXPECT_TRUE(ok.ok()) << ok.error_message();
  EXPECT_EQ(session.sample_count(), 10);
}

// Caps: samples per session, horizon, sessions and message size are
// RESOURCE_EXHAUSTED naming the flag to raise; nothing is stored.
TEST_F(SessionArchiveTest, CapsAreResourceExhausted) {
  StopServer();
  options_.max_message_mb = 1;
  options_.limits.max_sessions = 2;
  options_.limits.max_samples_per_session = 10;
  options_.limits.max_horizon = 5;
  StartServer();

  v1::SessionArchive archive = ValidArchive("capped");
  *archive.add_samples() = PendulumTransitions(1, 10, 71)[0];
  ExpectStatus(client_->ImportSession(archive).status(),
               absl::StatusCode::kResourceExhausted, "--max_samples_per_session");
  archive = ValidArchive("capped");
  archive.mutable_config()->set_horizon(6);
  ExpectStatus(client_->ImportSession(archive).status(),
               absl::StatusCode::kResourceExhausted, "--max_horizon");
  EXPECT_EQ(SessionCount(), 0);
  ASSERT_TRUE(client_->ImportSession(ValidArchive("one")).ok());
  ASSERT_TRUE(client_->ImportSession(ValidArchive("two")).ok());
  ExpectStatus(client_->ImportSession(ValidArchive("three")).status(),
               absl::StatusCode::kResourceExhausted, "its cap");

  // An archive beyond the server's 1 MiB message limit: gRPC refuses it, the
  // client says which limit to raise.
  archive = ValidArchive("huge");
  archive.clear_samples();
  for (const v1::Transition& t : PendulumTransitions(20000, 0, 72)) {
    *archive.add_samples() = t;
  }
  ASSERT_GT(archive.ByteSizeLong(), 1u << 20);
  ExpectStatus(client_->ImportSession(archive).status(),
               absl::StatusCode::kResourceExhausted, "--max_message_mb");

  // A stored session whose archive is beyond the limit: the server says so.
  StopServer();
  options_.limits.max_sessions = 10;
  options_.limits.max_samples_per_session = 20000;
  // The session is never fitted here, so it only keeps its samples; fitted, it
  // would take an estimated 39 GiB, more than the default budget allows.
  options_.memory_budget_bytes = int64_t{1} << 40;
  StartServer();
  const std::string name = Create("big").name();
  for (int start = 0; start < 20000; start += 4000) {
    std::vector<v1::Transition> batch(archive.samples().begin() + start,
                                      archive.samples().begin() + start + 4000);
    Add(name, {batch});
  }
  ExpectStatus(client_->ExportSession(name).status(),
               absl::StatusCode::kResourceExhausted, "--max_message_mb");
}

}  // namespace
}  // namespace excite::testing
