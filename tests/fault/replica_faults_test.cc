// Faults of a scaled-out excite, with real processes (tests/support/local_cluster.h):
// PostgreSQL, three excite-server replicas, HAProxy in front, and excite-sim
// plants exploring through it. Every plant records what was acknowledged (its
// --trajectory is written after each AddData returned OK); at the end every
// acknowledged sample must be stored, exactly once.

#include <signal.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "client/excite_client.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "server/service/config_text.h"
#include "tests/support/local_cluster.h"

#ifndef EXCITE_SERVER_BINARY
#error "EXCITE_SERVER_BINARY must name excite-server"
#endif
#ifndef EXCITE_SIM_BINARY
#error "EXCITE_SIM_BINARY must name excite-sim"
#endif
#ifndef EXCITE_SOURCE_DIR
#error "EXCITE_SOURCE_DIR must name the source tree"
#endif

namespace excite::testing {
namespace {

using ::testing::HasSubstr;
using Clock = std::chrono::steady_clock;

constexpr auto kLeaseTtl = std::chrono::milliseconds(5000);
// What the README states: a dead replica's sessions are served again within
// the lease plus the clients' retry backoff (at most 2 s), well under 10 s.
constexpr auto kServedAgainBound = std::chrono::seconds(10);

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// The sequences in an excite-sim --trajectory file (its last column).
std::vector<int64_t> AcknowledgedSequences(const std::string& path) {
  std::ifstream in(path);
  std::vector<int64_t> sequences;
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    int64_t sequence = 0;
    if (absl::SimpleAtoi(line.substr(line.rfind(',') + 1), &sequence)) {
      sequences.push_back(sequence);
    }
  }
  return sequences;
}

class ReplicaFaultsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    LocalClusterOptions options;
    options.replicas = 3;
    options.server_binary = EXCITE_SERVER_BINARY;
    options.haproxy_config =
        std::string(EXCITE_SOURCE_DIR) + "/deploy/haproxy/haproxy.cfg";
    options.lease_ttl = kLeaseTtl;
    absl::StatusOr<std::unique_ptr<LocalCluster>> cluster = LocalCluster::Start(options);
    ASSERT_TRUE(cluster.ok()) << cluster.status();
    cluster_ = *std::move(cluster);
    client::ClientOptions client_options;
    client_options.default_deadline = std::chrono::seconds(20);
    proxy_ = client::ExciteClient::Connect(cluster_->proxy_address(), client_options);
  }

  void TearDown() override {
    if (HasFailure() && cluster_ != nullptr) {
      std::cerr << cluster_->Logs();
      for (size_t i = 0; i < plants_.size(); ++i) {
        std::cerr << "--- plant " << i << "\n" << plants_[i]->Log();
      }
    }
  }

  // Starts `count` pendulum plants (rec, `samples` each) through the proxy.
  void StartPlants(int count, int samples) {
    for (int i = 0; i < count; ++i) {
      const std::string id = absl::StrCat("plant-", i);
      plants_.push_back(std::make_unique<ChildProcess>(
          std::vector<std::string>{
              EXCITE_SIM_BINARY,
              absl::StrCat("--server=", cluster_->proxy_address()),
              absl::StrCat("--config=", EXCITE_SOURCE_DIR,
                           "/sim/configs/pendulum.textproto"),
              "--strategy=rec",
              absl::StrCat("--samples=", samples),
              absl::StrCat("--seed=", i + 1),
              absl::StrCat("--session_id=", id),
              "--keep_session",
              // Cheaper than the paper's refit at every step: the test is about
              // faults, not about exploration.
              "--session_override=refit { growth: 0.1 }",
              absl::StrCat("--trajectory=", cluster_->dir(), "/", id, ".csv"),
              "--retry_unavailable_s=40",
          },
          absl::StrCat(cluster_->dir(), "/", id, ".log")));
      ids_.push_back(id);
    }
  }

  // The samples stored for `id`, read through the proxy.
  std::vector<int64_t> StoredSequences(const std::string& id) {
    absl::StatusOr<v1::SessionArchive> archive = proxy_->ExportSession("sessions/" + id);
    for (int attempt = 0; attempt < 100 && absl::IsUnavailable(archive.status());
         ++attempt) {
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
      archive = proxy_->ExportSession("sessions/" + id);
    }
    EXPECT_TRUE(archive.ok()) << id << ": " << archive.status();
    std::vector<int64_t> sequences;
    if (archive.ok()) {
      for (const v1::Transition& t : archive->samples())
        sequences.push_back(t.sequence());
    }
    return sequences;
  }

  // Every plant ended well, and each acknowledged sample is stored exactly once.
  void ExpectNothingLost() {
    for (size_t i = 0; i < plants_.size(); ++i) {
      EXPECT_EQ(plants_[i]->Wait(std::chrono::minutes(4)), 0) << ids_[i] << ":\n"
                                                              << plants_[i]->Log();
    }
    for (const std::string& id : ids_) {
      const std::vector<int64_t> acknowledged =
          AcknowledgedSequences(absl::StrCat(cluster_->dir(), "/", id, ".csv"));
      const std::vector<int64_t> stored = StoredSequences(id);
      const std::set<int64_t> distinct(stored.begin(), stored.end());
      EXPECT_EQ(distinct.size(), stored.size()) << id << ": a sample stored twice";
      for (int64_t sequence : acknowledged) {
        EXPECT_EQ(distinct.count(sequence), 1u)
            << id << ": acknowledged sample " << sequence << " was lost";
      }
      EXPECT_GT(acknowledged.size(), 0u) << id;
      std::cout << id << ": " << acknowledged.size() << " acknowledged, " << stored.size()
                << " stored\n";
    }
  }

  // Replica -> number of sessions it owns, from the database.
  std::map<std::string, int> Owners() {
    std::map<std::string, int> owners;
    for (int i = 0; i < cluster_->replicas(); ++i) {
      absl::StatusOr<std::string> n = cluster_->postgres().Query(
          absl::StrCat("SELECT count(*) FROM sessions WHERE owner = '",
                       LocalCluster::replica_id(i), "'"),
          "cluster");
      int count = 0;
      if (n.ok() && absl::SimpleAtoi(*n, &count))
        owners[LocalCluster::replica_id(i)] = count;
    }
    return owners;
  }

  // Waits until every plant's session holds at least `samples` samples.
  void WaitForSamples(int samples) {
    const Clock::time_point end = Clock::now() + std::chrono::minutes(3);
    while (Clock::now() < end) {
      absl::StatusOr<v1::ListSessionsResponse> listed = proxy_->ListSessions(100, "");
      int ready = 0;
      if (listed.ok()) {
        for (const v1::Session& s : listed->sessions())
          ready += s.sample_count() >= samples;
      }
      if (ready >= static_cast<int>(ids_.size())) return;
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
    }
    FAIL() << "the plants did not reach " << samples << " samples";
  }

  std::unique_ptr<LocalCluster> cluster_;
  std::unique_ptr<client::ExciteClient> proxy_;
  std::vector<std::unique_ptr<ChildProcess>> plants_;
  std::vector<std::string> ids_;
};

TEST_F(ReplicaFaultsTest, KillNineOfOneReplicaLosesNothingAndItsSessionsMove) {
  StartPlants(6, 70);
  WaitForSamples(20);
  // Kill the replica that serves the most sessions, mid-exploration.
  const std::map<std::string, int> before = Owners();
  int victim = 0;
  for (int i = 1; i < cluster_->replicas(); ++i) {
    if (before.at(LocalCluster::replica_id(i)) >
        before.at(LocalCluster::replica_id(victim))) {
      victim = i;
    }
  }
  const std::string victim_id = LocalCluster::replica_id(victim);
  std::vector<std::string> moved;
  for (const std::string& id : ids_) {
    absl::StatusOr<std::string> owner = cluster_->postgres().Query(
        absl::StrCat("SELECT owner FROM sessions WHERE id = '", id, "'"), "cluster");
    if (owner.ok() && *owner == victim_id) moved.push_back(id);
  }
  ASSERT_FALSE(moved.empty());
  const Clock::time_point killed = Clock::now();
  cluster_->KillReplica(victim);

  // Each of its sessions is served again (a call answers) within the bound.
  double slowest_s = 0;
  for (const std::string& id : moved) {
    absl::Status status;
    do {
      status = proxy_->GetSession("sessions/" + id).status();
      if (status.ok()) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    } while (Clock::now() - killed < std::chrono::seconds(30));
    ASSERT_TRUE(status.ok()) << id << ": " << status;
    slowest_s = std::max(slowest_s, SecondsSince(killed));
  }
  std::cout << "SIGKILL of " << victim_id << " (" << moved.size()
            << " sessions): all served again after " << slowest_s << " s\n";
  EXPECT_LT(slowest_s, std::chrono::duration<double>(kServedAgainBound).count());
  // The replica comes back while the plants explore: the proxy routes its
  // sessions to it again, and the replicas that took them hand them back.
  ASSERT_TRUE(cluster_->StartReplica(victim).ok());
  ExpectNothingLost();
}

TEST_F(ReplicaFaultsTest, PostgresRestartUnderLoadIsUnavailableThenRecovers) {
  StartPlants(4, 60);
  WaitForSamples(15);
  std::vector<pid_t> pids;
  for (int i = 0; i < cluster_->replicas(); ++i)
    pids.push_back(cluster_->replica(i)->pid());

  ASSERT_TRUE(cluster_->postgres().Stop().ok());
  // Meanwhile a call that needs the store fails with UNAVAILABLE (no retries
  // on this client), and says why.
  client::ClientOptions no_retry;
  no_retry.default_deadline = std::chrono::seconds(10);
  std::unique_ptr<client::ExciteClient> direct =
      client::ExciteClient::Connect(cluster_->proxy_address(), no_retry);
  v1::Transition t;
  t.set_sequence(1000000);
  for (int i = 0; i < 2; ++i) {
    t.add_state(0.1);
    t.add_next_state(0.1);
  }
  t.add_input(0.0);
  absl::StatusOr<v1::AddDataResponse> down = direct->AddData("sessions/plant-0", {{t}});
  EXPECT_TRUE(absl::IsUnavailable(down.status())) << down.status();
  EXPECT_THAT(down.status().message(), HasSubstr("PostgreSQL"));
  absl::StatusOr<v1::ListSessionsResponse> listed = direct->ListSessions(10, "");
  EXPECT_TRUE(absl::IsUnavailable(listed.status())) << listed.status();
  std::this_thread::sleep_for(std::chrono::seconds(3));
  ASSERT_TRUE(cluster_->postgres().StartAgain().ok());

  ExpectNothingLost();
  // The replicas recovered by themselves: the same processes, still serving.
  for (int i = 0; i < cluster_->replicas(); ++i) {
    EXPECT_TRUE(cluster_->replica(i)->running());
    EXPECT_EQ(cluster_->replica(i)->pid(), pids[static_cast<size_t>(i)]);
  }
  EXPECT_TRUE(direct->ListSessions(10, "").ok());
  // The probe's sample was refused, never stored.
  for (int64_t sequence : StoredSequences("plant-0")) EXPECT_NE(sequence, 1000000);
}

TEST_F(ReplicaFaultsTest, APausedReplicaThatResumesCannotWriteSessionsThatMoved) {
  // Direct connections, no proxy: the test decides which replica is asked.
  client::ClientOptions options;
  options.default_deadline = std::chrono::seconds(20);
  std::unique_ptr<client::ExciteClient> a =
      client::ExciteClient::Connect(cluster_->replica_address(0), options);
  std::unique_ptr<client::ExciteClient> b =
      client::ExciteClient::Connect(cluster_->replica_address(1), options);
  absl::StatusOr<v1::SessionConfig> config = service::ParseSessionConfigText(R"pb(
    state_dim: 1
    input_dim: 1
    input_bounds { lower: -1 upper: 1 }
    noise { variance: 0.0001 }
    kernel {
      fit: false
      fixed {
        signal_variance: 1
        lengthscales: [ 1, 1 ]
        noise_variance: 0.0001
      }
    }
  )pb");
  ASSERT_TRUE(config.ok()) << config.status();
  ASSERT_TRUE(a->CreateSession(*config, "paused").ok());
  const auto batch = [](int64_t first, int64_t count) {
    std::vector<v1::Transition> out;
    for (int64_t s = first; s < first + count; ++s) {
      v1::Transition t;
      t.set_sequence(s);
      t.add_state(0.01 * static_cast<double>(s));
      t.add_input(0.5);
      t.add_next_state(0.01 * static_cast<double>(s) + 0.05);
      out.push_back(t);
    }
    return out;
  };
  ASSERT_TRUE(a->AddData("sessions/paused", {batch(0, 10)}).ok());  // A owns it

  cluster_->replica(0)->Signal(SIGSTOP);
  const Clock::time_point paused = Clock::now();
  // B takes it once A's lease ran out (A cannot renew while stopped).
  absl::StatusOr<v1::AddDataResponse> taken;
  do {
    taken = b->AddData("sessions/paused", {batch(10, 10)});
    if (taken.ok()) break;
    ASSERT_TRUE(absl::IsUnavailable(taken.status())) << taken.status();
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  } while (Clock::now() - paused < std::chrono::seconds(20));
  ASSERT_TRUE(taken.ok()) << taken.status();
  std::cout << "B took the session " << SecondsSince(paused) << " s after A stopped\n";
  EXPECT_GE(Clock::now() - paused, kLeaseTtl - std::chrono::seconds(1));
  EXPECT_EQ(taken->sample_count(), 20);

  cluster_->replica(0)->Signal(SIGCONT);
  // A comes back believing nothing happened: its writes are refused.
  absl::StatusOr<v1::AddDataResponse> stale =
      a->AddData("sessions/paused", {batch(20, 5)});
  EXPECT_TRUE(absl::IsUnavailable(stale.status())) << stale.status();
  EXPECT_THAT(stale.status().message(), HasSubstr("replica-1"));
  // B carries on; nothing of A's attempt is stored.
  absl::StatusOr<v1::AddDataResponse> more =
      b->AddData("sessions/paused", {batch(20, 3)});
  ASSERT_TRUE(more.ok()) << more.status();
  EXPECT_EQ(more->stored(), 3);
  EXPECT_EQ(more->sample_count(), 23);
  absl::StatusOr<v1::SessionArchive> archive = b->ExportSession("sessions/paused");
  ASSERT_TRUE(archive.ok()) << archive.status();
  EXPECT_EQ(archive->samples_size(), 23);
}

}  // namespace
}  // namespace excite::testing
