// No number a request can carry may poison a session: what is out of range is
// INVALID_ARGUMENT naming the field and stores nothing, and whatever is accepted
// leaves a session that answers Predict and PlanInputs (also after a restart).

#include <array>
#include <cmath>
#include <iostream>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "gtest/gtest.h"
#include "server/service/config_validation.h"
#include "server/store/sqlite_store.h"
#include "sqlite3.h"
#include "tests/service/pendulum_data.h"
#include "tests/service/service_fixture.h"

namespace excite::service {
namespace {

using ::excite::testing::ExpectStatus;
using ::excite::testing::PendulumConfig;
using ::excite::testing::PendulumFixedKernelConfig;
using ::excite::testing::PendulumHyperparameters;
using ::excite::testing::PendulumTransitions;
using ::excite::testing::ServiceTest;

v1::Transition MakeTransition(std::vector<double> x, double u, std::vector<double> next,
                              int64_t sequence) {
  v1::Transition t;
  for (double v : x) t.add_state(v);
  t.add_input(u);
  for (double v : next) t.add_next_state(v);
  t.set_sequence(sequence);
  return t;
}

v1::SessionConfig FixedKernelConfig() {
  const v1::Hyperparameters unit = PendulumHyperparameters(1.0, {1.0, 1.0, 1.0});
  return PendulumFixedKernelConfig(unit, unit);
}

class HostileValuesTest : public ServiceTest {
 protected:
  // Predict at one point and PlanInputs from one state both succeed.
  void ExpectAnswers(const std::string& name) {
    v1::PredictRequest predict;
    predict.set_session(name);
    for (double v : {0.1, -0.2, 0.3}) predict.add_inputs(v);
    absl::StatusOr<v1::PredictResponse> predicted = client_->Predict(predict);
    ASSERT_TRUE(predicted.ok()) << name << ": " << predicted.status();
    for (double v : predicted->mean()) EXPECT_TRUE(std::isfinite(v));
    absl::StatusOr<v1::PlanInputsResponse> plan = client_->PlanInputs(name, {0.0, 0.0});
    ASSERT_TRUE(plan.ok()) << name << ": " << plan.status();
  }
};

TEST_F(HostileValuesTest, HugeFiniteTransitionsAreRejectedAndStoreNothing) {
  for (const v1::SessionConfig& config : {PendulumConfig(), FixedKernelConfig()}) {
    const std::string name =
        Create(config.kernel().fit() ? "fitted" : "fixed", config).name();
    Add(name, {PendulumTransitions(10, 0, 3)});
    // The requests: a delta target that overflows, and 1e154, whose
    // square overflows in a fitted kernel's standardisation.
    for (double huge : {1e308, 1e154, 1e31}) {
      absl::StatusOr<v1::AddDataResponse> added =
          client_->AddData(name, {{MakeTransition({huge, 0}, 0, {-huge, 0}, 100)}});
      ExpectStatus(added.status(), absl::StatusCode::kInvalidArgument,
                   "transitions[0].state[0]: must be finite and within +-1e+30");
      absl::StatusOr<v1::Session> session = client_->GetSession(name);
      ASSERT_TRUE(session.ok());
      EXPECT_EQ(session->sample_count(), 10) << huge;
    }
    // The largest accepted values go in, and the session still answers.
    Add(name, {{MakeTransition({1e30, -1e30}, 3, {-1e30, 1e30}, 10)}});
    ExpectAnswers(name);
  }
  StopServer();
  StartServer();
  ExpectAnswers("sessions/fitted");
  ExpectAnswers("sessions/fixed");
}

TEST_F(HostileValuesTest, HugeQueriesAreInvalidArgumentNotInternal) {
  const std::string name = Create("queries").name();
  Add(name, {PendulumTransitions(10, 0, 3)});
  v1::PredictRequest predict;
  predict.set_session(name);
  for (double v : {-1e308, 0.0, 1.7e308}) predict.add_inputs(v);
  ExpectStatus(client_->Predict(predict).status(), absl::StatusCode::kInvalidArgument,
               "inputs[0]: (point 0) must be finite and within +-1e+30");
  ExpectStatus(client_->PlanInputs(name, {0.0, 1e308}).status(),
               absl::StatusCode::kInvalidArgument,
               "state[1]: must be finite and within +-1e+30");
  // At the edge of the range both still answer: far from the data the model
  // is its prior.
  predict.clear_inputs();
  for (double v : {1e30, -1e30, 1e30}) predict.add_inputs(v);
  absl::StatusOr<v1::PredictResponse> far = client_->Predict(predict);
  ASSERT_TRUE(far.ok()) << far.status();
  for (double v : far->variance()) EXPECT_TRUE(std::isfinite(v) && v > 0);
  absl::StatusOr<v1::PlanInputsResponse> plan = client_->PlanInputs(name, {1e30, -1e30});
  ASSERT_TRUE(plan.ok()) << plan.status();
}

TEST_F(HostileValuesTest, ExtremeButValidHyperparametersStillAnswer) {
  // The corners of the accepted ranges (value_ranges.h) with the largest data.
  for (const auto& [lengthscale, variance, noise] : std::vector<std::array<double, 3>>{
           {1e-50, 1e100, 1e-100}, {1e50, 1e-100, 1e100}, {1e-50, 1e-100, 1e-100}}) {
    v1::SessionConfig config = FixedKernelConfig();
    config.mutable_noise()->set_variance(1e-30);
    for (v1::Hyperparameters& h : *config.mutable_kernel()->mutable_fixed()) {
      h.set_signal_variance(variance);
      for (int l = 0; l < h.lengthscales_size(); ++l) h.set_lengthscales(l, lengthscale);
      h.set_noise_variance(noise);
    }
    const std::string name =
        Create(absl::StrCat("corner-", lengthscale > 1 ? "long" : "short", "-",
                            variance > 1 ? "high" : "low", "-",
                            noise > 1 ? "noisy" : "clean"),
               config)
            .name();
    Add(name, {PendulumTransitions(10, 0, 3),
               {MakeTransition({1e30, -1e30}, 3, {-1e30, 1e30}, 10)}});
    ExpectAnswers(name);
  }
}

TEST_F(HostileValuesTest, ASessionAnOlderVersionPoisonedIsSetAsideNotFatal) {
  const std::string bad = Create("poisoned").name();
  const std::string good = Create("healthy").name();
  Add(bad, {PendulumTransitions(10, 0, 3)});
  Add(good, {PendulumTransitions(10, 0, 4)});
  StopServer();
  {
    // What a server before value_ranges.h stored: a delta target that overflows.
    absl::StatusOr<std::unique_ptr<store::SqliteStore>> store =
        store::SqliteStore::Open(options_.data_dir);
    ASSERT_TRUE(store.ok()) << store.status();
    store::SampleRecord poison;
    poison.sequence = 10;
    poison.state = {1e308, 0.0};
    poison.input = {0.0};
    poison.next_state = {-1e308, 0.0};
    ASSERT_TRUE((*store)->InsertSamples("poisoned", /*fence=*/0, {poison}).ok());
  }
  StartServer();  // used to fail: "restoring samples: ... overflows"
  ExpectAnswers(good);
  absl::StatusOr<v1::Session> described = client_->GetSession(bad);
  ASSERT_TRUE(described.ok()) << described.status();
  EXPECT_EQ(described->sample_count(), 11);
  v1::PredictRequest predict;
  predict.set_session(bad);
  for (double v : {0.1, -0.2, 0.3}) predict.add_inputs(v);
  ExpectStatus(client_->Predict(predict).status(), absl::StatusCode::kDataLoss,
               "session sessions/poisoned is damaged");
  ExpectStatus(client_->AddData(bad, {PendulumTransitions(1, 20, 5)}).status(),
               absl::StatusCode::kDataLoss, "ExportSession reads what is readable");
  absl::StatusOr<v1::SessionArchive> exported = client_->ExportSession(bad);
  ASSERT_TRUE(exported.ok()) << exported.status();
  EXPECT_EQ(exported->samples_size(), 11);
  EXPECT_TRUE(client_->DeleteSession(bad).ok());
  EXPECT_EQ(client_->GetSession(bad).status().code(), absl::StatusCode::kNotFound);
}

// Damage to the store itself (a disk, a hand edit, another program): a sample
// row whose blob is 2 bytes, and a session whose config no longer parses. Each
// used to stop the server from starting ("DATA_LOSS: session bad sample 3: a blob
// of doubles has 2 bytes"); now each session is set aside and the rest served.
TEST_F(HostileValuesTest, DamagedRowsSetTheirSessionAsideNotTheServer) {
  const std::string blob = Create("blob").name();
  const std::string config = Create("config").name();
  const std::string good = Create("fine").name();
  Add(blob, {PendulumTransitions(10, 0, 3)});
  Add(config, {PendulumTransitions(10, 0, 4)});
  Add(good, {PendulumTransitions(10, 0, 5)});
  StopServer();
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open((options_.data_dir + "/excite.db").c_str(), &db), SQLITE_OK);
    char* error = nullptr;
    const char* damage =
        "UPDATE samples SET state = x'0102' WHERE session_id = 'blob' AND sequence = 3;"
        "UPDATE sessions SET config = x'ffffffff' WHERE id = 'config';";
    EXPECT_EQ(sqlite3_exec(db, damage, nullptr, nullptr, &error), SQLITE_OK)
        << (error != nullptr ? error : "");
    sqlite3_free(error);
    sqlite3_close(db);
  }
  StartServer();
  ExpectAnswers(good);

  v1::PredictRequest predict;
  for (double v : {0.1, -0.2, 0.3}) predict.add_inputs(v);
  predict.set_session(blob);
  ExpectStatus(client_->Predict(predict).status(), absl::StatusCode::kDataLoss,
               "session sessions/blob is damaged: 1 stored samples cannot be read "
               "(sequence 3)");
  predict.set_session(config);
  ExpectStatus(client_->Predict(predict).status(), absl::StatusCode::kDataLoss,
               "session sessions/config is damaged: its stored config does not parse");
  ExpectStatus(client_->PlanInputs(config, {0.0, 0.0}).status(),
               absl::StatusCode::kDataLoss, "sessions/config is damaged");

  // Listed, described as far as readable, exported as far as readable.
  absl::StatusOr<v1::ListSessionsResponse> listed = client_->ListSessions(0, "");
  ASSERT_TRUE(listed.ok()) << listed.status();
  EXPECT_EQ(listed->sessions_size(), 3);
  EXPECT_EQ(client_->GetSession(blob)->sample_count(), 9);
  absl::StatusOr<v1::SessionArchive> exported = client_->ExportSession(blob);
  ASSERT_TRUE(exported.ok()) << exported.status();
  EXPECT_EQ(exported->samples_size(), 9);
  // The config's samples too (StoredValuesTest checks the archive's contents).
  exported = client_->ExportSession(config);
  ASSERT_TRUE(exported.ok()) << exported.status();
  EXPECT_EQ(exported->samples_size(), 10);
  // Deleting removes them; the server restarts clean.
  EXPECT_TRUE(client_->DeleteSession(blob).ok());
  EXPECT_TRUE(client_->DeleteSession(config).ok());
  StopServer();
  StartServer();
  listed = client_->ListSessions(0, "");
  ASSERT_TRUE(listed.ok()) << listed.status();
  EXPECT_EQ(listed->sessions_size(), 1);
  ExpectAnswers(good);
}

// A number a hostile or broken client might send.
double HostileNumber(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const double sign = unit(rng) < 0.5 ? -1.0 : 1.0;
  const double p = unit(rng);
  if (p < 0.45) return 2.0 * (unit(rng) - 0.5) * 3.0;                // plausible
  if (p < 0.60) return sign * std::pow(10.0, -30 + 60 * unit(rng));  // accepted extremes
  if (p < 0.70) return sign * 1e30;                                  // the edge
  if (p < 0.80) return sign * std::pow(10.0, 30 + 278 * unit(rng));  // out of range
  if (p < 0.85) return sign * std::numeric_limits<double>::denorm_min();
  if (p < 0.90) return 0.0;
  if (p < 0.95) return sign * std::numeric_limits<double>::infinity();
  return std::numeric_limits<double>::quiet_NaN();
}

// 10,000 requests (12 s in the release build); 1,000 under the sanitizers, which
// are ~25 times slower here: the suite runs in full once, not again under them.
#if defined(__SANITIZE_ADDRESS__)
constexpr int kHostileRequests = 1000;
#else
constexpr int kHostileRequests = 10000;
#endif

// An integer a hostile or broken client might send in an int64 field.
int64_t HostileInteger(std::mt19937_64& rng) {
  constexpr int64_t kMax = std::numeric_limits<int64_t>::max();
  constexpr int64_t kLastTimestampMs = 253402300799999;  // 9999-12-31T23:59:59.999Z
  const std::array<int64_t, 12> edges = {0,
                                         1,
                                         -1,
                                         kLastTimestampMs,
                                         kLastTimestampMs + 1,
                                         (int64_t{1} << 53) + 1,
                                         int64_t{1} << 62,
                                         kMax,
                                         kMax - 1,
                                         std::numeric_limits<int64_t>::min(),
                                         1700000000000,
                                         int64_t{1} << 31};
  std::uniform_int_distribution<size_t> pick(0, edges.size());
  const size_t i = pick(rng);
  return i < edges.size() ? edges[i] : static_cast<int64_t>(rng());
}

// A number a request may carry: HostileNumber drawn again until accepted
// (finite, within +-1e30), so extremes and the edge stay likely.
double AcceptedNumber(std::mt19937_64& rng) {
  while (true) {
    const double x = HostileNumber(rng);
    if (std::isfinite(x) && std::abs(x) <= 1e30) return x;
  }
}

// A pendulum archive of a few samples at the edges of what an import accepts
// (times up to the end of 9999, sequences up to 2^53, hyperparameters at the
// ends of their ranges), with at most one aspect made hostile (an int64 or a
// number out of range, a bad version, a long name): ImportSession must refuse it
// naming the field, or store it so that every later read of it succeeds. About
// a third come out clean, so the sanitizers' 1,000 requests still import some.
v1::SessionArchive HostileArchive(std::mt19937_64& rng, const v1::SessionConfig& config,
                                  int id) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const int hostile = std::uniform_int_distribution<int>(0, 10)(rng);  // <= 2: none
  constexpr int64_t kLastTimestampMs = 253402300799999;
  constexpr int64_t kMaxSequence = int64_t{1} << 53;
  const auto pick = [&rng](std::initializer_list<double> values) {
    const size_t k = std::uniform_int_distribution<size_t>(0, values.size() - 1)(rng);
    return *(values.begin() + k);
  };
  v1::SessionArchive archive;
  archive.set_format_version(hostile == 3 ? static_cast<int32_t>(rng()) : 1);
  archive.set_session_id(absl::StrCat("imported-", id));
  *archive.mutable_config() = config;
  const int samples = static_cast<int>(unit(rng) * 4);
  const auto number = [&]() {
    return hostile == 4 ? HostileNumber(rng) : AcceptedNumber(rng);
  };
  for (int i = 0; i < samples; ++i) {
    v1::Transition t = MakeTransition(
        {number(), number()}, number(), {number(), number()},
        hostile == 5 ? HostileInteger(rng) : (unit(rng) < 0.5 ? i : kMaxSequence - i));
    t.set_timestamp_s(hostile == 6 ? HostileNumber(rng) : unit(rng) * 1e9);
    *archive.add_samples() = t;
  }
  if (unit(rng) < 0.5) {
    for (int i = 0; i < config.state_dim(); ++i) {
      *archive.add_hyperparameters() =
          hostile == 7 ? PendulumHyperparameters(std::abs(HostileNumber(rng)),
                                                 {std::abs(HostileNumber(rng)), 1.0,
                                                  std::abs(HostileNumber(rng))},
                                                 std::abs(HostileNumber(rng)))
                       : PendulumHyperparameters(pick({1e-100, 1.0, 1e100}),
                                                 {pick({1e-50, 1.0, 1e50}), 1.0, 2.0},
                                                 pick({1e-100, 1e-4, 1e100}));
    }
    archive.set_fitted_sample_count(
        hostile == 8 ? HostileInteger(rng) : static_cast<int64_t>(unit(rng) * samples));
  }
  archive.set_created_unix_ms(
      hostile == 9
          ? HostileInteger(rng)
          : static_cast<int64_t>(pick({0, 1, 1.7e12, double{kLastTimestampMs}})));
  if (hostile == 10 || unit(rng) < 0.3) {
    archive.set_display_name(
        std::string(hostile == 10 ? 300 : static_cast<size_t>(unit(rng) * 256), 'd'));
  }
  if (unit(rng) < 0.3) (*archive.mutable_labels())["plant"] = "pendulum";
  return archive;
}

TEST_F(HostileValuesTest, RandomHostileRequestsLeaveEverySessionAnswering) {
  std::vector<std::string> names;
  {
    v1::SessionConfig fitted = PendulumConfig();
    fitted.mutable_refit()->set_every_samples(100);  // keeps the test fast
    fitted.mutable_planner()->set_max_iterations(5);
    fitted.set_horizon(3);
    v1::SessionConfig next = fitted;
    next.set_target(v1::TARGET_NEXT);
    v1::SessionConfig fixed = FixedKernelConfig();
    fixed.mutable_planner()->set_max_iterations(5);
    fixed.set_horizon(3);
    names = {Create("h-fitted", fitted).name(), Create("h-next", next).name(),
             Create("h-fixed", fixed).name()};
  }
  for (const std::string& name : names) Add(name, {PendulumTransitions(20, 0, 5)});
  std::mt19937_64 rng(2026);
  std::uniform_int_distribution<int> pick(0, static_cast<int>(names.size()) - 1);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<int64_t> next_sequence(names.size(), 20);
  absl::StatusOr<v1::SessionConfig> imported_config =
      ValidatedSessionConfig(FixedKernelConfig(), "config");
  ASSERT_TRUE(imported_config.ok()) << imported_config.status();
  int imports = 0;
  int accepted = 0, rejected = 0, internal = 0;
  constexpr int kRequests = kHostileRequests;
  for (int r = 0; r < kRequests; ++r) {
    const int s = pick(rng);
    const std::string& name = names[static_cast<size_t>(s)];
    const double kind = unit(rng);
    absl::Status status;
    if (kind < 0.6) {
      std::vector<double> x{HostileNumber(rng), HostileNumber(rng)};
      std::vector<double> y{HostileNumber(rng), HostileNumber(rng)};
      status =
          client_
              ->AddData(name,
                        {{MakeTransition(x, HostileNumber(rng), y, next_sequence[s]++)}})
              .status();
    } else if (kind < 0.95) {
      v1::PredictRequest predict;
      predict.set_session(name);
      for (int i = 0; i < 3; ++i) predict.add_inputs(HostileNumber(rng));
      status = client_->Predict(predict).status();
    } else if (kind < 0.97) {
      status =
          client_->PlanInputs(name, {HostileNumber(rng), HostileNumber(rng)}).status();
    } else {
      // Every accepted import is readable at once; a refused one stores nothing.
      const v1::SessionArchive archive = HostileArchive(rng, *imported_config, r);
      absl::StatusOr<v1::Session> imported = client_->ImportSession(archive);
      status = imported.status();
      if (imported.ok()) {
        ++imports;
        EXPECT_TRUE(client_->GetSession(imported->name()).ok()) << r;
        EXPECT_TRUE(client_->ExportSession(imported->name()).ok()) << r;
      } else {
        EXPECT_EQ(client_->GetSession("sessions/" + archive.session_id()).status().code(),
                  absl::StatusCode::kNotFound)
            << r;
      }
    }
    if (status.ok()) {
      ++accepted;
    } else if (status.code() == absl::StatusCode::kInvalidArgument ||
               (status.code() == absl::StatusCode::kResourceExhausted &&
                absl::StrContains(status.message(), "per session"))) {
      ++rejected;  // a refusal that names its reason: out of range, or the cap
    } else {
      ++internal;
      ADD_FAILURE() << "request " << r << " on " << name << ": " << status;
    }
  }
  std::cout << kRequests << " hostile requests: " << accepted << " accepted, " << rejected
            << " refused (INVALID_ARGUMENT, or the sample cap), " << internal
            << " other; " << imports << " archives imported\n";
  EXPECT_GT(accepted, kRequests / 10);
  EXPECT_GT(rejected, kRequests / 10);
  EXPECT_GT(imports, 0);
  for (const std::string& name : names) ExpectAnswers(name);
  EXPECT_EQ(ExpectEveryReadSucceeds(), static_cast<int>(names.size()) + imports);
  StopServer();
  StartServer();
  for (const std::string& name : names) ExpectAnswers(name);
  EXPECT_EQ(ExpectEveryReadSucceeds(), static_cast<int>(names.size()) + imports);
}

}  // namespace
}  // namespace excite::service
