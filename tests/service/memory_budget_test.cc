// The server's memory budget: a request whose sessions' estimated memory would
// exceed it gets RESOURCE_EXHAUSTED saying what it would take, and stores nothing;
// deleting a session gives its share back; sessions restored beyond a smaller
// budget are still served but may not grow.

#include "server/session/memory_budget.h"

#include <malloc.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "client/excite_client.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "server/gp/dynamics_model.h"
#include "server/service/excite_server.h"
#include "tests/service/pendulum_data.h"
#include "tests/service/service_fixture.h"
#include "tests/support/temp_dir.h"

namespace excite::service {
namespace {

using session::DefaultMemoryBudgetBytes;
using session::MemoryBudget;
using session::ReturnFreedMemory;

using ::excite::testing::PendulumConfig;
using ::excite::testing::PendulumFixedKernelConfig;
using ::excite::testing::PendulumHyperparameters;
using ::excite::testing::PendulumTransitions;
using ::testing::HasSubstr;

// Fixed hyperparameters: Predict then only factorises (a fit of hundreds of
// samples can outlast the config's time budget under the sanitizers).
// Exact GPs at any size: their estimate grows as n^2.
v1::SessionConfig FixedConfig() {
  const v1::Hyperparameters h = PendulumHyperparameters(1.0, {1.0, 1.0, 1.0});
  v1::SessionConfig config = PendulumFixedKernelConfig(h, h);
  config.mutable_sparse()->set_above_samples(0);
  return config;
}

// A pendulum session's model with n samples, as the budget estimates it (the
// session's own 32 KiB aside).
int64_t ModelBytes(int64_t n) { return gp::DynamicsModel::PeakBytes(n, 2, 1, 2); }

class MemoryBudgetTest : public ::testing::Test {
 protected:
  void Start(int64_t budget_bytes) {
    client_.reset();
    server_.reset();
    ServerOptions options;
    options.listen = "127.0.0.1:0";
    options.data_dir = tmp_.path() + "/data";
    options.memory_budget_bytes = budget_bytes;
    absl::StatusOr<std::unique_ptr<ExciteServer>> server = ExciteServer::Start(options);
    ASSERT_TRUE(server.ok()) << server.status();
    server_ = *std::move(server);
    client_ = client::ExciteClient::Connect(server_->address());
  }

  // A Predict at one point succeeds.
  void ExpectPredicts(const std::string& name) {
    v1::PredictRequest predict;
    predict.set_session(name);
    for (double v : {0.1, 0.2, 0.3}) predict.add_inputs(v);
    absl::StatusOr<v1::PredictResponse> predicted = client_->Predict(predict);
    EXPECT_TRUE(predicted.ok()) << name << ": " << predicted.status();
  }

  int64_t SampleCount(const std::string& name) {
    absl::StatusOr<v1::Session> session = client_->GetSession(name);
    return session.ok() ? session->sample_count() : -1;
  }

  excite::testing::TempDir tmp_;
  std::unique_ptr<ExciteServer> server_;
  std::unique_ptr<client::ExciteClient> client_;
};

TEST_F(MemoryBudgetTest, RefusesGrowthBeyondTheBudgetAndStoresNothing) {
  // Room for one session of 300 samples, not 400.
  Start(ModelBytes(300) + (ModelBytes(400) - ModelBytes(300)) / 2 + (64 << 10));
  absl::StatusOr<v1::Session> session = client_->CreateSession(FixedConfig(), "a");
  ASSERT_TRUE(session.ok()) << session.status();
  ASSERT_TRUE(client_->AddData("sessions/a", {PendulumTransitions(300, 0, 1)}).ok());

  absl::StatusOr<v1::AddDataResponse> refused =
      client_->AddData("sessions/a", {PendulumTransitions(100, 300, 2)});
  EXPECT_EQ(refused.status().code(), absl::StatusCode::kResourceExhausted);
  EXPECT_THAT(refused.status().message(),
              HasSubstr("session sessions/a with 400 samples (100 more) would take an "
                        "estimated"));
  EXPECT_THAT(refused.status().message(), HasSubstr("--memory_budget_mb"));
  EXPECT_EQ(SampleCount("sessions/a"), 300);
  // A smaller step still fits, and the session still answers.
  ASSERT_TRUE(client_->AddData("sessions/a", {PendulumTransitions(10, 300, 3)}).ok());
  EXPECT_EQ(SampleCount("sessions/a"), 310);
  ExpectPredicts("sessions/a");

  // The whole session as an import does not fit beside it...
  absl::StatusOr<v1::SessionArchive> archive = client_->ExportSession("sessions/a");
  ASSERT_TRUE(archive.ok()) << archive.status();
  absl::StatusOr<v1::Session> imported = client_->ImportSession(*archive, "b");
  EXPECT_EQ(imported.status().code(), absl::StatusCode::kResourceExhausted);
  EXPECT_THAT(imported.status().message(), HasSubstr("importing sessions/b with 310"));
  EXPECT_EQ(client_->GetSession("sessions/b").status().code(),
            absl::StatusCode::kNotFound);
  // ...but it does once the original is deleted: its share is given back.
  ASSERT_TRUE(client_->DeleteSession("sessions/a").ok());
  imported = client_->ImportSession(*archive, "b");
  ASSERT_TRUE(imported.ok()) << imported.status();
  EXPECT_EQ(SampleCount("sessions/b"), 310);
}

// Above sparse.above_samples the estimate grows as n (the samples) plus the sparse
// models' and the subset fit's fixed size: a budget that holds an exact session of
// 500 samples holds a sparse one of 3000 (hyperparameters fitted on 100).
TEST_F(MemoryBudgetTest, SparseSessionsGrowLinearly) {
  const auto sparse_bytes = [](int64_t n) {
    return gp::DynamicsModel::PeakBytes(n, 2, 1, 2, 100, 256, 100);
  };
  // Per sample: each output's sparse model keeps the inputs twice and the target,
  // twice while a refit builds the new model; the model's inputs and targets.
  EXPECT_EQ(sparse_bytes(30000) - sparse_bytes(3000), 27000 * 8 * (2 * 2 * 7 + 5));
  EXPECT_LT(sparse_bytes(3000), ModelBytes(500));
  Start(ModelBytes(500) + (64 << 10));
  v1::SessionConfig config = FixedConfig();
  config.mutable_sparse()->set_above_samples(100);
  config.mutable_sparse()->set_fit_samples(100);
  ASSERT_TRUE(client_->CreateSession(config, "a").ok());
  ASSERT_TRUE(client_->AddData("sessions/a", {PendulumTransitions(150, 0, 1)}).ok());
  ExpectPredicts("sessions/a");  // fitted: sparse from here on
  ASSERT_TRUE(client_->AddData("sessions/a", {PendulumTransitions(2850, 150, 2)}).ok());
  EXPECT_EQ(SampleCount("sessions/a"), 3000);
  ExpectPredicts("sessions/a");
  // An exact session of 500 samples does not fit beside it.
  ASSERT_TRUE(client_->CreateSession(FixedConfig(), "b").ok());
  EXPECT_EQ(
      client_->AddData("sessions/b", {PendulumTransitions(500, 0, 3)}).status().code(),
      absl::StatusCode::kResourceExhausted);
}

TEST_F(MemoryBudgetTest, RefusesNewSessionsWhenFull) {
  Start(120 << 10);  // three empty sessions of 36 KiB each (32 + the empty model)
  for (const char* id : {"a", "b", "c"}) {
    ASSERT_TRUE(client_->CreateSession(PendulumConfig(), id).ok()) << id;
  }
  absl::StatusOr<v1::Session> refused = client_->CreateSession(PendulumConfig(), "d");
  EXPECT_EQ(refused.status().code(), absl::StatusCode::kResourceExhausted);
  EXPECT_THAT(refused.status().message(), HasSubstr("a new session sessions/d"));
  EXPECT_EQ(client_->GetSession("sessions/d").status().code(),
            absl::StatusCode::kNotFound);
}

TEST_F(MemoryBudgetTest, SessionsRestoredBeyondABudgetAreServedButDoNotGrow) {
  Start(0);  // the default: ample here
  ASSERT_TRUE(client_->CreateSession(FixedConfig(), "a").ok());
  ASSERT_TRUE(client_->AddData("sessions/a", {PendulumTransitions(200, 0, 1)}).ok());
  Start(ModelBytes(100));  // restart with a budget smaller than the session
  EXPECT_EQ(SampleCount("sessions/a"), 200);
  ExpectPredicts("sessions/a");
  EXPECT_EQ(
      client_->AddData("sessions/a", {PendulumTransitions(1, 200, 2)}).status().code(),
      absl::StatusCode::kResourceExhausted);
  EXPECT_EQ(SampleCount("sessions/a"), 200);
}

TEST(MemoryBudget, ReserveIsAllOrNothing) {
  MemoryBudget budget(1000);
  EXPECT_TRUE(budget.Reserve(600, "x").ok());
  const absl::Status refused = budget.Reserve(500, "y");
  EXPECT_EQ(refused.code(), absl::StatusCode::kResourceExhausted);
  EXPECT_THAT(std::string(refused.message()), HasSubstr("y would take"));
  EXPECT_EQ(budget.used(), 600);
  budget.Release(600);
  EXPECT_TRUE(budget.Reserve(1000, "z").ok());
  budget.ForceReserve(10);
  EXPECT_EQ(budget.used(), 1010);
  EXPECT_GT(DefaultMemoryBudgetBytes(), int64_t{64} << 20);
}

TEST(MemoryBudget, EstimateCountsWhatTheModelHolds) {
  // Per output (2): the factor with its 25 % room, the cached K, the inputs twice
  // (z_dim 3) and three vectors; the model's inputs and targets; five n x n per
  // fitting thread (2).
  const int64_t n = 2000;
  const int64_t capacity = 2508;
  const int64_t doubles =
      2 * (capacity * capacity + n * n + 2 * n * 3 + 3 * n) + n * 5 + 2 * 5 * n * n;
  EXPECT_EQ(ModelBytes(n), doubles * 8);
  EXPECT_EQ(gp::DynamicsModel::PeakBytes(0, 2, 1, 2), int64_t{2 * 16 * 16 * 8});
  // One fitting thread per output at most.
  EXPECT_EQ(
      gp::DynamicsModel::PeakBytes(n, 1, 1, 8) - gp::DynamicsModel::PeakBytes(n, 1, 1, 1),
      0);
}

// Freed blocks that glibc keeps in the heap are given back to the system.
TEST(ReturnFreedMemory, GivesTheHeapsFreePagesBack) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "the sanitizer's allocator replaces glibc's";
#else
  const auto resident_bytes = [] {
    std::ifstream statm("/proc/self/statm");
    int64_t size = 0, resident = 0;
    statm >> size >> resident;
    return resident * sysconf(_SC_PAGESIZE);
  };
  // 64 blocks of 1 MiB on the heap, where neither mapping nor free() trims them.
  mallopt(M_MMAP_THRESHOLD, 256 << 20);
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
  std::vector<char*> blocks;
  for (int i = 0; i < 64; ++i) {
    blocks.push_back(static_cast<char*>(std::malloc(1 << 20)));
    std::memset(blocks.back(), 1, 1 << 20);
  }
  for (char* block : blocks) std::free(block);
  const int64_t kept = resident_bytes();
  ReturnFreedMemory();
  EXPECT_GT(kept - resident_bytes(), int64_t{48} << 20);
#endif
}

}  // namespace
}  // namespace excite::service
