// Two excite servers (in this process) on one real PostgreSQL database: a
// session is served by one replica at a time, moves when asked or when its
// owner stops, and every call of any replica sees the same data.

#include <chrono>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "client/excite_client.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "server/service/excite_server.h"
#include "tests/service/service_fixture.h"
#include "tests/support/postgres_environment.h"

namespace excite::testing {
namespace {

using ::testing::HasSubstr;
using Clock = std::chrono::steady_clock;

v1::Transition PendulumTransition(int64_t sequence) {
  v1::Transition t;
  t.set_sequence(sequence);
  const double theta = 0.1 * static_cast<double>(sequence % 17) - 0.8;
  const double omega = 0.05 * static_cast<double>(sequence % 11) - 0.25;
  const double u = 0.3 * static_cast<double>(sequence % 5) - 0.6;
  t.add_state(theta);
  t.add_state(omega);
  t.add_input(u);
  t.add_next_state(theta + 0.05 * omega);
  t.add_next_state(omega + 0.05 * (u - 9.81 * theta));
  return t;
}

std::vector<v1::Transition> Batch(int64_t first, int64_t count) {
  std::vector<v1::Transition> batch;
  for (int64_t i = first; i < first + count; ++i) batch.push_back(PendulumTransition(i));
  return batch;
}

const PostgresEnvironment* const kPostgres = PostgresEnvironment::Register();

class ReplicasTest : public ::testing::Test {
 protected:
  void SetUp() override {
    postgres_ = PostgresEnvironment::server();
    ASSERT_NE(postgres_, nullptr);
    dbname_ = PostgresEnvironment::NewDatabase("replicas");
    ASSERT_FALSE(dbname_.empty());
    Start(0);
    Start(1);
  }

  void Start(int i) {
    service::ServerOptions options;
    options.listen = "127.0.0.1:0";
    options.store_url = postgres_->url(dbname_);
    options.store_password = postgres_->password();
    options.replica_id = absl::StrCat("replica-", i);
    options.lease_ttl = std::chrono::milliseconds(1500);
    absl::StatusOr<std::unique_ptr<service::ExciteServer>> server =
        service::ExciteServer::Start(options);
    ASSERT_TRUE(server.ok()) << server.status();
    servers_[i] = *std::move(server);
    clients_[i] = client::ExciteClient::Connect(servers_[i]->address());
    ASSERT_TRUE(clients_[i]->WaitForReady(std::chrono::seconds(5)).ok());
  }

  // Retries `call` on UNAVAILABLE for up to `within`; the last status.
  template <typename Call>
  absl::Status Eventually(Call&& call, std::chrono::milliseconds within) {
    const Clock::time_point end = Clock::now() + within;
    absl::Status status;
    do {
      status = call();
      if (!absl::IsUnavailable(status)) return status;
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    } while (Clock::now() < end);
    return status;
  }

  PostgresServer* postgres_ = nullptr;
  std::string dbname_;
  std::unique_ptr<service::ExciteServer> servers_[2];
  std::unique_ptr<client::ExciteClient> clients_[2];
};

TEST_F(ReplicasTest, ASessionIsServedByOneReplicaAndMovesWhenAskedOnceIdle) {
  ASSERT_TRUE(clients_[0]->CreateSession(PendulumConfig(), "moving").ok());
  ASSERT_TRUE(clients_[0]->AddData("sessions/moving", {Batch(0, 20)}).ok());

  // Any replica describes it, from the store, without taking it...
  absl::StatusOr<v1::Session> described_by_1 = clients_[1]->GetSession("sessions/moving");
  ASSERT_TRUE(described_by_1.ok()) << described_by_1.status();
  EXPECT_EQ(described_by_1->sample_count(), 20);
  EXPECT_EQ(*postgres_->Query("SELECT owner || ' ' || (handoff_wanted_by IS NULL) FROM "
                              "sessions WHERE id = 'moving'",
                              dbname_),
            "replica-0 true");
  // ...but replica 1 may not serve it while replica 0 holds it.
  v1::PredictRequest predict;
  predict.set_session("sessions/moving");
  for (double z : {0.1, 0.2, 0.3}) predict.add_inputs(z);
  absl::StatusOr<v1::PredictResponse> refused = clients_[1]->Predict(predict);
  ASSERT_TRUE(absl::IsUnavailable(refused.status())) << refused.status();
  EXPECT_THAT(refused.status().message(), HasSubstr("replica-0"));

  // ...but replica 0 hands it over once idle (it was asked), within a second or
  // two; replica 1 then serves everything replica 0 stored.
  absl::StatusOr<v1::AddDataResponse> added;
  const Clock::time_point asked = Clock::now();
  ASSERT_TRUE(Eventually(
                  [&]() {
                    added = clients_[1]->AddData("sessions/moving", {Batch(15, 10)});
                    return added.status();
                  },
                  std::chrono::seconds(5))
                  .ok())
      << added.status();
  EXPECT_LT(Clock::now() - asked, std::chrono::seconds(3));
  EXPECT_EQ(added->stored(), 5);      // 20-24
  EXPECT_EQ(added->duplicates(), 5);  // 15-19, stored through replica 0
  EXPECT_EQ(added->sample_count(), 25);

  // Now replica 0 is refused, and writes nothing.
  absl::StatusOr<v1::AddDataResponse> stale =
      clients_[0]->AddData("sessions/moving", {Batch(25, 1)});
  EXPECT_TRUE(absl::IsUnavailable(stale.status())) << stale.status();
  EXPECT_THAT(stale.status().message(), HasSubstr("replica-1"));
  absl::StatusOr<v1::Session> described = clients_[1]->GetSession("sessions/moving");
  ASSERT_TRUE(described.ok()) << described.status();
  EXPECT_EQ(described->sample_count(), 25);
  EXPECT_EQ(described->last_sequence(), 24);
}

TEST_F(ReplicasTest, AReplicaThatStopsHandsItsSessionsOverAtOnce) {
  ASSERT_TRUE(clients_[0]->CreateSession(PendulumConfig(), "handed").ok());
  ASSERT_TRUE(clients_[0]->AddData("sessions/handed", {Batch(0, 30)}).ok());
  v1::PredictRequest predict;
  predict.set_session("sessions/handed");
  for (double z : {0.1, 0.2, 0.3}) predict.add_inputs(z);
  absl::StatusOr<v1::PredictResponse> before = clients_[0]->Predict(predict);
  ASSERT_TRUE(before.ok()) << before.status();

  clients_[0].reset();
  servers_[0].reset();  // drains, then releases its leases
  const Clock::time_point stopped = Clock::now();
  absl::StatusOr<v1::PredictResponse> after = clients_[1]->Predict(predict);
  ASSERT_TRUE(after.ok()) << after.status();  // no wait for the lease to expire
  EXPECT_LT(Clock::now() - stopped, std::chrono::seconds(1));
  // The same data and the saved hyperparameters: the same prediction.
  ASSERT_EQ(after->mean_size(), before->mean_size());
  for (int i = 0; i < before->mean_size(); ++i) {
    EXPECT_NEAR(after->mean(i), before->mean(i), 1e-9);
    EXPECT_NEAR(after->variance(i), before->variance(i), 1e-9);
  }
}

TEST_F(ReplicasTest, CreateListAndImportWorkThroughAnyReplica) {
  ASSERT_TRUE(clients_[0]->CreateSession(PendulumConfig(), "from-0").ok());
  ASSERT_TRUE(clients_[1]->CreateSession(PendulumConfig(), "from-1").ok());
  absl::StatusOr<v1::Session> clash =
      clients_[1]->CreateSession(PendulumConfig(), "from-0");
  EXPECT_TRUE(absl::IsAlreadyExists(clash.status())) << clash.status();
  ASSERT_TRUE(clients_[0]->AddData("sessions/from-0", {Batch(0, 7)}).ok());
  for (int i = 0; i < 2; ++i) {
    absl::StatusOr<v1::ListSessionsResponse> listed = clients_[i]->ListSessions(10, "");
    ASSERT_TRUE(listed.ok()) << listed.status();
    ASSERT_EQ(listed->sessions_size(), 2);
    EXPECT_EQ(listed->sessions(0).name(), "sessions/from-0");
    EXPECT_EQ(listed->sessions(0).sample_count(), 7);  // live on 0, stored for 1
    EXPECT_EQ(listed->sessions(0).last_sequence(), 6);
    EXPECT_EQ(listed->sessions(1).name(), "sessions/from-1");
  }
  absl::StatusOr<v1::SessionArchive> archive =
      clients_[0]->ExportSession("sessions/from-0");
  ASSERT_TRUE(archive.ok()) << archive.status();
  ASSERT_TRUE(clients_[1]->ImportSession(*archive, "copy").ok());
  absl::StatusOr<v1::Session> copy = clients_[1]->GetSession("sessions/copy");
  ASSERT_TRUE(copy.ok()) << copy.status();
  EXPECT_EQ(copy->sample_count(), 7);
}

TEST_F(ReplicasTest, DeleteThroughTheOwnerRemovesItEverywhere) {
  ASSERT_TRUE(clients_[0]->CreateSession(PendulumConfig(), "doomed").ok());
  ASSERT_TRUE(clients_[0]->AddData("sessions/doomed", {Batch(0, 5)}).ok());
  ASSERT_TRUE(clients_[0]->DeleteSession("sessions/doomed").ok());
  EXPECT_TRUE(absl::IsNotFound(clients_[1]->GetSession("sessions/doomed").status()));
  EXPECT_TRUE(absl::IsNotFound(clients_[0]->GetSession("sessions/doomed").status()));
  // The id is free again for either replica.
  ASSERT_TRUE(clients_[1]->CreateSession(PendulumConfig(), "doomed").ok());
  absl::StatusOr<v1::Session> fresh = clients_[1]->GetSession("sessions/doomed");
  ASSERT_TRUE(fresh.ok()) << fresh.status();
  EXPECT_EQ(fresh->sample_count(), 0);
}

}  // namespace
}  // namespace excite::testing
