// The Prometheus endpoint of excite-server: scraped over loopback after a few
// RPCs, its counters match what was called; silent clients neither block a scrape
// nor the server's shutdown.

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "client/excite_client.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "server/service/config_text.h"
#include "server/service/excite_server.h"
#include "tests/service/pendulum_data.h"
#include "tests/support/temp_dir.h"

namespace excite::service {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;
using ::testing::StartsWith;

// One HTTP/1.0 GET on 127.0.0.1:port; the whole reply ("" on error).
std::string HttpGet(int port, const std::string& path) {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return "";
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<uint16_t>(port));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  std::string reply;
  if (connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) == 0) {
    const std::string request = absl::StrCat("GET ", path, " HTTP/1.0\r\n\r\n");
    if (send(fd, request.data(), request.size(), 0) ==
        static_cast<ssize_t>(request.size())) {
      char buffer[4096];
      ssize_t n = 0;
      while ((n = recv(fd, buffer, sizeof(buffer), 0)) > 0) {
        reply.append(buffer, static_cast<size_t>(n));
      }
    }
  }
  close(fd);
  return reply;
}

// A connection to 127.0.0.1:port that has sent `partial` (an unfinished request)
// and then says nothing; closed on destruction.
class SilentClient {
 public:
  SilentClient(int port, const std::string& partial) {
    fd_ = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(static_cast<uint16_t>(port));
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    connected_ = fd_ >= 0 &&
                 connect(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) == 0 &&
                 send(fd_, partial.data(), partial.size(), 0) ==
                     static_cast<ssize_t>(partial.size());
  }
  ~SilentClient() {
    if (fd_ >= 0) close(fd_);
  }
  SilentClient(const SilentClient&) = delete;
  SilentClient& operator=(const SilentClient&) = delete;
  bool connected() const { return connected_; }

 private:
  int fd_ = -1;
  bool connected_ = false;
};

// A server with a metrics endpoint on free loopback ports, and a client.
class MetricsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ServerOptions options;
    options.listen = "127.0.0.1:0";
    options.data_dir = tmp_.path() + "/data";
    options.metrics_listen = "127.0.0.1:0";
    absl::StatusOr<std::unique_ptr<ExciteServer>> server = ExciteServer::Start(options);
    ASSERT_TRUE(server.ok()) << server.status();
    server_ = *std::move(server);
    port_ = server_->metrics_port();
    ASSERT_GT(port_, 0);
    client_ = client::ExciteClient::Connect(server_->address());
  }

  // A pendulum session (state_dim 2, input_dim 1, strategy random) with the given
  // noise and kernel settings (textproto) holding `samples` transitions.
  absl::StatusOr<v1::Session> PendulumSession(const std::string& id,
                                              const std::string& noise_and_kernel,
                                              int samples) {
    absl::StatusOr<v1::SessionConfig> config = ParseSessionConfigText(
        absl::StrCat("state_dim: 2 input_dim: 1 input_bounds { lower: -3 upper: 3 } ",
                     noise_and_kernel, " strategy: STRATEGY_RANDOM horizon: 5"));
    if (!config.ok()) return config.status();
    absl::StatusOr<v1::Session> session = client_->CreateSession(*config, id);
    if (!session.ok()) return session.status();
    absl::StatusOr<v1::AddDataResponse> added = client_->AddData(
        session->name(), {excite::testing::PendulumTransitions(samples, 0, 3)});
    if (!added.ok()) return added.status();
    return session;
  }

  static v1::PredictRequest PredictOnePoint(const std::string& session) {
    v1::PredictRequest predict;
    predict.set_session(session);
    for (double v : {0.1, 0.2, 0.3}) predict.add_inputs(v);
    return predict;
  }

  excite::testing::TempDir tmp_;
  std::unique_ptr<ExciteServer> server_;
  int port_ = 0;
  std::unique_ptr<client::ExciteClient> client_;
};

TEST_F(MetricsTest, CountsRpcsSessionsAndSamples) {
  client::ExciteClient* client = client_.get();
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(client->ListSessions(0, "").ok());
  EXPECT_EQ(client->GetSession("sessions/nope").status().code(),
            absl::StatusCode::kNotFound);
  absl::StatusOr<v1::Session> session =
      PendulumSession("m1",
                      "noise { variance: 1e-6 fit: true } kernel { fit: true restarts: 1 "
                      "max_iterations: 20 }",
                      7);
  ASSERT_TRUE(session.ok()) << session.status();
  ASSERT_TRUE(client->PlanInputs(session->name(), {0.1, 0.0}).ok());
  ASSERT_TRUE(client->Predict(PredictOnePoint(session->name())).ok());  // the refit

  const std::string reply = HttpGet(port_, "/metrics");
  EXPECT_THAT(reply, StartsWith("HTTP/1.1 200 OK\r\n"));
  const std::string s = ",grpc_service=\"excite.v1.ExplorationService\"";
  // prometheus-cpp sorts labels by name.
  EXPECT_THAT(reply, HasSubstr(absl::StrCat(
                         "excite_rpc_total{code=\"OK\",grpc_method=\"ListSessions\"", s,
                         "} 3\n")));
  EXPECT_THAT(reply, HasSubstr(absl::StrCat(
                         "excite_rpc_total{code=\"NOT_FOUND\",grpc_method=\"GetSession\"",
                         s, "} 1\n")));
  EXPECT_THAT(reply,
              HasSubstr(absl::StrCat("excite_rpc_latency_seconds_count{code=\"OK\","
                                     "grpc_method=\"ListSessions\"",
                                     s, "} 3\n")));
  EXPECT_THAT(reply,
              HasSubstr(absl::StrCat("excite_rpc_latency_seconds_bucket{code=\"OK\","
                                     "grpc_method=\"ListSessions\"",
                                     s, ",le=\"+Inf\"} 3\n")));
  EXPECT_THAT(reply, HasSubstr("excite_samples_stored_total 7\n"));
  EXPECT_THAT(reply, HasSubstr("excite_samples 7\n"));
  EXPECT_THAT(reply, HasSubstr("excite_sessions 1\n"));
  EXPECT_THAT(reply, HasSubstr("# TYPE excite_memory_estimate_bytes gauge\n"));
  EXPECT_THAT(reply, HasSubstr("# TYPE excite_memory_budget_bytes gauge\n"));
  EXPECT_THAT(reply, Not(HasSubstr("excite_memory_estimate_bytes 0\n")));
  // By the strategy that planned and how the solve ended: plans that hit a limit
  // are countable.
  EXPECT_THAT(reply, HasSubstr("excite_plan_seconds_count{solver_status=\"converged\","
                               "strategy=\"random\"} 1\n"));
  EXPECT_THAT(reply, HasSubstr("excite_plan_seconds_bucket{solver_status=\"converged\","
                               "strategy=\"random\",le=\"+Inf\"} 1\n"));
  EXPECT_THAT(reply, HasSubstr("excite_fit_seconds_count 1\n"));
  EXPECT_THAT(reply, HasSubstr("excite_fits_stopped_total 0\n"));
  EXPECT_THAT(reply,
              HasSubstr("excite_store_write_seconds_count{op=\"insert_samples\"} 1\n"));
  EXPECT_THAT(reply,
              HasSubstr("excite_store_write_seconds_count{op=\"save_model\"} 1\n"));
  // Served beside them: the process, the build and MUMPS's locks and copies (which
  // a random plan does not use).
  EXPECT_THAT(reply, HasSubstr("# TYPE process_cpu_seconds_total counter\n"));
  EXPECT_THAT(reply, HasSubstr("# TYPE process_resident_memory_bytes gauge\n"));
  EXPECT_THAT(reply, HasSubstr("# TYPE process_open_fds gauge\n"));
  EXPECT_THAT(
      reply,
      ::testing::ContainsRegex(
          "excite_build_info\\{commit=\"([0-9a-f]{12}(-dirty)?|unknown)\",version=\"" +
          std::string(EXCITE_PROJECT_VERSION) + "\"\\} 1\n"));
  EXPECT_THAT(reply, HasSubstr("excite_mumps_lock_acquisitions_total 0\n"));
  EXPECT_THAT(reply, HasSubstr("# TYPE excite_mumps_lock_wait_seconds_total counter\n"));
  EXPECT_THAT(reply, HasSubstr("# TYPE excite_mumps_lock_held_seconds_total counter\n"));
  EXPECT_THAT(reply, HasSubstr("excite_mumps_copies 1\n"));  // the process's own
  EXPECT_THAT(HttpGet(port_, "/other"), HasSubstr(" 404 Not Found\r\n"));
  EXPECT_THAT(reply, Not(HasSubstr("UNKNOWN")));
}

// Slow or silent clients on the metrics port (the old responder served one
// connection at a time, 2 s per read, and never checked for stop while reading):
// a scrape still answers at once, and the server still stops within its grace.
TEST_F(MetricsTest, SilentClientsBlockNeitherScrapesNorShutdown) {
  std::vector<std::unique_ptr<SilentClient>> silent;
  silent.push_back(std::make_unique<SilentClient>(port_, ""));
  silent.push_back(std::make_unique<SilentClient>(port_, "GET /metr"));
  for (const auto& client : silent) ASSERT_TRUE(client->connected());

  const auto scrape_start = std::chrono::steady_clock::now();
  EXPECT_THAT(HttpGet(port_, "/metrics"), StartsWith("HTTP/1.1 200 OK\r\n"));
  const double scrape_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - scrape_start)
          .count();
  EXPECT_LT(scrape_s, 1.0);

  const auto stop_start = std::chrono::steady_clock::now();
  server_->Shutdown(std::chrono::seconds(1));
  server_.reset();  // stops the metrics endpoint with the silent clients connected
  const double stop_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - stop_start)
          .count();
  std::cout << "scrape beside 2 silent clients: " << scrape_s
            << " s; shutdown with them connected: " << stop_s << " s\n";
  EXPECT_LT(stop_s, 5.0);  // the drain grace of excite-server
}

// A Predict whose deadline passes during a long refit: the server stops the fit
// (counted in excite_fits_stopped_total) instead of finishing it for a client that
// has gone, keeps the best hyperparameters so far, and the next call completes
// the fit.
TEST_F(MetricsTest, RefitStopsAtTheClientDeadlineAndResumes) {
  // 400 samples and 8 starts per output: a complete cold fit takes seconds here.
  absl::StatusOr<v1::Session> session =
      PendulumSession("slow",
                      "noise { variance: 1e-4 fit: true } kernel { fit: true restarts: 7 "
                      "max_iterations: 40 } planner { time_budget_s: 600 }",
                      400);
  ASSERT_TRUE(session.ok()) << session.status();
  const v1::PredictRequest predict = PredictOnePoint(session->name());

  client::ClientOptions hurried;
  hurried.default_deadline = std::chrono::milliseconds(100);
  std::unique_ptr<client::ExciteClient> impatient =
      client::ExciteClient::Connect(server_->address(), hurried);
  EXPECT_EQ(impatient->Predict(predict).status().code(),
            absl::StatusCode::kDeadlineExceeded);
  // The server notices at its next objective evaluation and records the stop.
  std::string reply;
  for (int i = 0; i < 200; ++i) {
    reply = HttpGet(port_, "/metrics");
    if (reply.find("excite_fit_seconds_count 1\n") != std::string::npos) break;
    usleep(50 * 1000);
  }
  EXPECT_THAT(reply, HasSubstr("excite_fits_stopped_total 1\n"));
  EXPECT_THAT(reply, HasSubstr("excite_fit_seconds_count 1\n"));

  // The rest of the fit, with time to spare (sanitizer builds are slow; the
  // session's time budget, which also bounds a Predict's refit, is 600 s).
  client::ClientOptions patient;
  patient.default_deadline = std::chrono::seconds(180);
  absl::StatusOr<v1::PredictResponse> predicted =
      client::ExciteClient::Connect(server_->address(), patient)->Predict(predict);
  ASSERT_TRUE(predicted.ok()) << predicted.status();
  reply = HttpGet(port_, "/metrics");
  EXPECT_THAT(reply, HasSubstr("excite_fits_stopped_total 1\n"));
  EXPECT_THAT(reply, HasSubstr("excite_fit_seconds_count 2\n"));
}

}  // namespace
}  // namespace excite::service
