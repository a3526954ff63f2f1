// Crash safety of the real excite-server binary: a client streams numbered
// transitions, the server is killed with SIGKILL at a random moment, restarted
// on the same data directory, and every acknowledged sample must be there
// exactly once; a retry of the unacknowledged tail then stores exactly the
// missing ones. With StreamData (one acknowledgement per message) on one long
// stream, what is stored after a kill is the acknowledged messages plus at most
// the one in flight.

#include <signal.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <iostream>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "client/excite_client.h"
#include "gtest/gtest.h"
#include "server/service/config_text.h"
#include "tests/service/server_process.h"
#include "tests/support/temp_dir.h"

namespace excite::service {
namespace {

using ::excite::testing::ListeningPort;
using ::excite::testing::ServerProcess;

constexpr int kCycles = 10;
constexpr int kBatch = 4;  // transitions per AddData message (one transaction)

v1::Transition MakeTransition(int64_t sequence) {
  const double x = std::sin(0.1 * static_cast<double>(sequence));
  const double u = std::cos(0.37 * static_cast<double>(sequence));
  v1::Transition t;
  t.add_state(x);
  t.add_input(u);
  t.add_next_state(0.9 * x + 0.1 * u);
  t.set_sequence(sequence);
  return t;
}

std::vector<v1::Transition> Range(int64_t first, int64_t end) {
  std::vector<v1::Transition> batch;
  for (int64_t s = first; s < end; ++s) batch.push_back(MakeTransition(s));
  return batch;
}

std::unique_ptr<client::ExciteClient> Connect(ServerProcess* server) {
  const std::string port = ListeningPort(server->ReadLine());
  if (port.empty()) return nullptr;
  client::ClientOptions options;
  options.default_deadline = std::chrono::milliseconds(10000);
  return client::ExciteClient::Connect("127.0.0.1:" + port, options);
}

// The one-dimensional session both tests stream into (fixed hyperparameters).
void CreateKillSession(const std::string& data_dir) {
  ServerProcess server(data_dir);
  auto client = Connect(&server);
  ASSERT_NE(client, nullptr);
  absl::StatusOr<v1::SessionConfig> config = ParseSessionConfigText(R"pb(
    state_dim: 1
    input_dim: 1
    input_bounds { lower: -1 upper: 1 }
    noise { variance: 0.0001 }
    # Fixed hyperparameters: the sessions grow to ~1500 samples, and an ML-II
    # fit of that size is seconds of CPU this durability test does not need.
    kernel {
      fit: false
      fixed {
        signal_variance: 1
        lengthscales: [ 2, 2 ]
        noise_variance: 0.0001
      }
    }
  )pb");
  ASSERT_TRUE(config.ok()) << config.status();
  ASSERT_TRUE(client->CreateSession(*config, "kill").ok());
}  // SIGKILLed by the destructor

TEST(KillRestartTest, AcknowledgedSamplesSurviveSigkillExactlyOnce) {
  excite::testing::TempDir tmp;
  const std::string data_dir = tmp.path() + "/data";
  const std::string session = "sessions/kill";
  std::mt19937 rng(12345);
  std::uniform_int_distribution<int> delay_ms(20, 400);

  CreateKillSession(data_dir);

  int64_t acked_end = 0;  // sequences [0, acked_end) were acknowledged
  int64_t sent_end = 0;   // sequences [0, sent_end) were sent at least once
  int64_t total_killed_unacked = 0;
  int64_t stored_unacked = 0;  // in flight at a kill, stored but not acknowledged
  for (int cycle = 0; cycle < kCycles; ++cycle) {
    ServerProcess server(data_dir);
    ASSERT_GT(server.pid(), 0);
    auto client = Connect(&server);
    ASSERT_NE(client, nullptr) << "cycle " << cycle;

    // After the restart: every acknowledged sample is there, none twice (the
    // stored sequences are a prefix [0, n) since messages are sent in order).
    absl::StatusOr<v1::Session> info = client->GetSession(session);
    ASSERT_TRUE(info.ok()) << info.status();
    EXPECT_GE(info->sample_count(), acked_end) << "cycle " << cycle;
    EXPECT_LE(info->sample_count(), sent_end) << "cycle " << cycle;
    EXPECT_EQ(info->last_sequence(), info->sample_count() - 1) << "cycle " << cycle;

    // Retrying the unacknowledged tail stores exactly the missing ones.
    if (sent_end > acked_end) {
      absl::StatusOr<v1::AddDataResponse> retry =
          client->AddData(session, {Range(acked_end, sent_end)});
      ASSERT_TRUE(retry.ok()) << retry.status();
      EXPECT_EQ(retry->stored(), sent_end - info->sample_count());
      EXPECT_EQ(retry->duplicates(), info->sample_count() - acked_end);
      EXPECT_EQ(retry->sample_count(), sent_end);
      total_killed_unacked += sent_end - acked_end;
      stored_unacked += info->sample_count() - acked_end;
      acked_end = sent_end;
    }
    if (acked_end >= 3) {
      v1::PredictRequest predict;
      predict.set_session(session);
      predict.add_inputs(0.1);
      predict.add_inputs(0.2);
      absl::StatusOr<v1::PredictResponse> prediction = client->Predict(predict);
      ASSERT_TRUE(prediction.ok()) << prediction.status();
      ASSERT_EQ(prediction->mean_size(), 1);
      EXPECT_NEAR(prediction->mean(0), 0.9 * 0.1 + 0.1 * 0.2, 0.05);
    }

    // Stream until killed at a random moment.
    std::atomic<bool> killed{false};
    const int delay = delay_ms(rng);
    std::thread killer([&server, &killed, delay]() {
      std::this_thread::sleep_for(std::chrono::milliseconds(delay));
      killed = true;
      kill(server.pid(), SIGKILL);
    });
    while (true) {
      const int64_t first = sent_end;
      sent_end = first + kBatch;
      absl::StatusOr<v1::AddDataResponse> response =
          client->AddData(session, {Range(first, sent_end)});
      if (!response.ok()) break;  // killed while in flight: not acknowledged
      EXPECT_EQ(response->stored(), kBatch);
      acked_end = sent_end;
      if (killed) break;  // acknowledged just before the kill
      // A plant's pace, not a flood: keeps the session at a few hundred samples per
      // cycle, so the restarted server's Predict (an O(n^3) factorisation) stays quick.
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    killer.join();
    std::cout << "cycle " << cycle << ": killed after " << delay << " ms, acked "
              << acked_end << ", sent " << sent_end << "\n";
  }

  // Final restart: all sent samples, exactly once, and the model predicts.
  ServerProcess server(data_dir);
  auto client = Connect(&server);
  ASSERT_NE(client, nullptr);
  absl::StatusOr<v1::Session> info = client->GetSession(session);
  ASSERT_TRUE(info.ok()) << info.status();
  EXPECT_GE(info->sample_count(), acked_end);
  absl::StatusOr<v1::AddDataResponse> retry =
      client->AddData(session, {Range(acked_end, sent_end)});
  ASSERT_TRUE(retry.ok()) << retry.status();
  EXPECT_EQ(retry->sample_count(), sent_end);
  EXPECT_EQ(retry->stored() + retry->duplicates(), sent_end - acked_end);
  info = client->GetSession(session);
  ASSERT_TRUE(info.ok());
  EXPECT_EQ(info->sample_count(), sent_end);
  EXPECT_EQ(info->last_sequence(), sent_end - 1);
  std::cout << kCycles << " SIGKILL cycles, " << sent_end << " samples, "
            << total_killed_unacked << " unacknowledged at a kill (retried), of which "
            << stored_unacked << " had been stored\n";
}

TEST(KillRestartTest, StreamDataAcknowledgesExactlyWhatSurvivesSigkill) {
  excite::testing::TempDir tmp;
  const std::string data_dir = tmp.path() + "/data";
  const std::string session = "sessions/kill";
  CreateKillSession(data_dir);
  std::mt19937 rng(777);
  std::uniform_int_distribution<int> delay_ms(20, 400);

  int64_t acked_end = 0;  // sequences [0, acked_end) were acknowledged
  int64_t in_flight = 0;  // transitions sent after the last acknowledgement
  int64_t stored_in_flight = 0;
  for (int cycle = 0; cycle < kCycles / 2; ++cycle) {
    ServerProcess server(data_dir);
    auto client = Connect(&server);
    ASSERT_NE(client, nullptr) << "cycle " << cycle;
    absl::StatusOr<v1::Session> info = client->GetSession(session);
    ASSERT_TRUE(info.ok()) << info.status();
    // Exactly the acknowledged messages, plus at most the one in flight.
    EXPECT_GE(info->sample_count(), acked_end) << "cycle " << cycle;
    EXPECT_LE(info->sample_count(), acked_end + in_flight) << "cycle " << cycle;
    stored_in_flight += info->sample_count() - acked_end;
    // Resume from the first unacknowledged message, as a plant would.
    std::unique_ptr<client::DataStream> stream = client->OpenDataStream(session);
    absl::StatusOr<v1::AddDataAck> resent =
        stream->Send(Range(acked_end, acked_end + in_flight));
    if (in_flight > 0) {
      ASSERT_TRUE(resent.ok()) << resent.status();
      EXPECT_EQ(resent->stored() + resent->duplicates(), in_flight);
      EXPECT_EQ(resent->sample_count(), acked_end + in_flight);
      acked_end += in_flight;
    }

    const int delay = delay_ms(rng);
    std::thread killer([&server, delay]() {
      std::this_thread::sleep_for(std::chrono::milliseconds(delay));
      kill(server.pid(), SIGKILL);
    });
    int messages = 0;
    while (true) {
      in_flight = kBatch;
      absl::StatusOr<v1::AddDataAck> ack =
          stream->Send(Range(acked_end, acked_end + kBatch));
      if (!ack.ok()) break;  // the stream broke: this message is unacknowledged
      EXPECT_EQ(ack->stored(), kBatch);
      EXPECT_EQ(ack->sample_count(), acked_end + kBatch);
      acked_end += kBatch;
      in_flight = 0;
      ++messages;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    killer.join();
    std::cout << "StreamData cycle " << cycle << ": killed after " << delay << " ms, "
              << messages << " messages acknowledged on one stream, acked " << acked_end
              << "\n";
  }
  ServerProcess server(data_dir);
  auto client = Connect(&server);
  ASSERT_NE(client, nullptr);
  absl::StatusOr<v1::Session> info = client->GetSession(session);
  ASSERT_TRUE(info.ok()) << info.status();
  EXPECT_GE(info->sample_count(), acked_end);
  EXPECT_LE(info->sample_count(), acked_end + in_flight);
  std::cout << "StreamData: " << acked_end
            << " acknowledged; of the in-flight messages at " << kCycles / 2 << " kills, "
            << stored_in_flight << " transitions had been stored\n";
}

}  // namespace
}  // namespace excite::service
