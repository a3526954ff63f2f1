// excite-fleet: many live sessions spread over replicas. Starts --replicas
// excite-server replicas on one PostgreSQL server behind HAProxy
// (tests/support/local_cluster.h), creates --sessions sessions through the proxy,
// streams --samples pendulum transitions into each, then has every session
// Predict and plan once (each replica takes the sessions the proxy routes to it),
// and reports how the sessions are spread (leases per replica, from the
// database), each replica's RSS, the latencies, and that ListSessions through
// the proxy sees them all. Exit 1 on any error.

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/flags/usage.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/synchronization/mutex.h"
#include "bench/load/load_stats.h"
#include "client/excite_client.h"
#include "server/service/config_text.h"
#include "tests/support/local_cluster.h"

ABSL_FLAG(int, replicas, 3, "Replicas behind the proxy (1..16).");
ABSL_FLAG(int, sessions, 1000, "Sessions to create and keep live (1..100000).");
ABSL_FLAG(int, samples, 20, "Samples streamed into each session.");
ABSL_FLAG(int, workers, 16, "Client threads.");
ABSL_FLAG(std::string, server_binary, EXCITE_SERVER_BINARY, "excite-server to start.");
ABSL_FLAG(std::string, haproxy_config, EXCITE_SOURCE_DIR "/deploy/haproxy/haproxy.cfg",
          "The HAProxy configuration to adapt.");

namespace {

using excite::bench::Percentile;
using excite::bench::RssKib;

using Clock = std::chrono::steady_clock;
namespace v1 = excite::v1;

constexpr char kConfig[] = R"pb(
  state_dim: 2
  input_dim: 1
  input_bounds { lower: -3 upper: 3 }
  state_bounds { lower: -3.2 upper: 3.2 }
  state_bounds { lower: -8 upper: 8 }
  noise { variance: 1e-4 fit: true }
  kernel { fit: true restarts: 0 max_iterations: 30 }
  horizon: 5
  planner { max_iterations: 20 time_budget_s: 5 }
)pb";

// Transitions of a damped pendulum (explicit Euler is enough for a load).
std::vector<v1::Transition> Transitions(int session, int count) {
  std::mt19937 rng(static_cast<uint32_t>(session + 1));
  std::uniform_real_distribution<double> unit(-1, 1);
  std::array<double, 2> x{unit(rng), unit(rng)};
  std::vector<v1::Transition> out;
  for (int i = 0; i < count; ++i) {
    const double u = 3 * unit(rng);
    const std::array<double, 2> y{
        x[0] + 0.05 * x[1], x[1] + 0.05 * (-9.81 * std::sin(x[0]) - 0.1 * x[1] + u)};
    v1::Transition t;
    t.set_sequence(i);
    t.add_state(x[0]);
    t.add_state(x[1]);
    t.add_input(u);
    t.add_next_state(y[0]);
    t.add_next_state(y[1]);
    out.push_back(t);
    x = y;
  }
  return out;
}

struct Latencies {
  absl::Mutex mu;
  std::map<std::string, std::vector<double>> ms ABSL_GUARDED_BY(mu);
  std::atomic<int64_t> errors{0};
  std::vector<std::string> first_errors ABSL_GUARDED_BY(mu);

  void Add(const std::string& what, Clock::time_point start, const absl::Status& s) {
    const double elapsed =
        std::chrono::duration<double, std::milli>(Clock::now() - start).count();
    absl::MutexLock lock(&mu);
    ms[what].push_back(elapsed);
    if (!s.ok()) {
      ++errors;
      if (first_errors.size() < 10) first_errors.push_back(what + ": " + s.ToString());
    }
  }
};

// Runs `work(i)` for i in [0, n) on `workers` threads.
template <typename Work>
void Parallel(int n, int workers, Work&& work) {
  std::atomic<int> next{0};
  std::vector<std::thread> threads;
  for (int w = 0; w < workers; ++w) {
    threads.emplace_back([&]() {
      for (int i = next++; i < n; i = next++) work(i);
    });
  }
  for (std::thread& t : threads) t.join();
}

int Run() {
  const int replicas = absl::GetFlag(FLAGS_replicas);
  const int sessions = absl::GetFlag(FLAGS_sessions);
  const int samples = absl::GetFlag(FLAGS_samples);
  const int workers = std::max(1, absl::GetFlag(FLAGS_workers));
  if (replicas < 1 || replicas > 16 || sessions < 1 || sessions > 100000 || samples < 2) {
    std::fprintf(stderr,
                 "excite-fleet: --replicas in [1, 16], --sessions in [1, 100000], "
                 "--samples >= 2\n");
    return 2;
  }
  absl::StatusOr<v1::SessionConfig> config =
      excite::service::ParseSessionConfigText(kConfig);
  if (!config.ok()) return 2;

  std::string dir = std::filesystem::temp_directory_path() / "excite-fleet-XXXXXX";
  if (mkdtemp(dir.data()) == nullptr) return 1;
  excite::testing::LocalClusterOptions options;
  options.replicas = replicas;
  options.server_binary = absl::GetFlag(FLAGS_server_binary);
  options.haproxy_config = absl::GetFlag(FLAGS_haproxy_config);
  options.server_flags = {"--log_level=warning"};
  options.dir = dir;
  absl::StatusOr<std::unique_ptr<excite::testing::LocalCluster>> cluster =
      excite::testing::LocalCluster::Start(options);
  if (!cluster.ok()) {
    std::fprintf(stderr, "excite-fleet: %s\n", cluster.status().ToString().c_str());
    return 1;
  }
  int64_t rss_start = 0;
  for (int i = 0; i < replicas; ++i) rss_start += RssKib((*cluster)->replica(i)->pid());

  // One channel per worker: each multiplexes its sessions' calls through the proxy.
  std::vector<std::unique_ptr<excite::client::ExciteClient>> clients;
  for (int w = 0; w < workers; ++w) {
    clients.push_back(excite::client::ExciteClient::Connect((*cluster)->proxy_address()));
  }
  const auto client_of = [&](int i) {
    return clients[static_cast<size_t>(i % workers)].get();
  };
  Latencies latencies;
  const Clock::time_point start = Clock::now();
  Parallel(sessions, workers, [&](int i) {
    excite::client::ExciteClient* client = client_of(i);
    const std::string id = absl::StrCat("fleet-", i);
    Clock::time_point t = Clock::now();
    absl::StatusOr<v1::Session> created = client->CreateSession(*config, id);
    latencies.Add("CreateSession", t, created.status());
    if (!created.ok()) return;
    t = Clock::now();
    latencies.Add("AddData", t,
                  client->AddData("sessions/" + id, {Transitions(i, samples)}).status());
  });
  const double stored_s = std::chrono::duration<double>(Clock::now() - start).count();
  Parallel(sessions, workers, [&](int i) {
    excite::client::ExciteClient* client = client_of(i);
    const std::string name = absl::StrCat("sessions/fleet-", i);
    v1::PredictRequest predict;
    predict.set_session(name);
    for (double z : {0.1, -0.2, 0.5, 1.0, 0.0, -1.0}) predict.add_inputs(z);
    Clock::time_point t = Clock::now();
    latencies.Add("Predict (first: lease, load, fit)", t,
                  client->Predict(predict).status());
    t = Clock::now();
    latencies.Add("PlanInputs", t, client->PlanInputs(name, {0.1, 0.0}).status());
  });
  const double live_s = std::chrono::duration<double>(Clock::now() - start).count();

  std::printf(
      "excite-fleet: %d sessions of %d samples over %d replicas (PostgreSQL, "
      "HAProxy): stored after %.1f s, all served (Predict + PlanInputs) after "
      "%.1f s\n",
      sessions, samples, replicas, stored_s, live_s);
  int owned = 0;
  int64_t rss_end = 0;
  for (int i = 0; i < replicas; ++i) {
    const std::string id = excite::testing::LocalCluster::replica_id(i);
    absl::StatusOr<std::string> count = (*cluster)->postgres().Query(
        absl::StrCat("SELECT count(*) FROM sessions WHERE owner = '", id,
                     "' AND lease_expires > clock_timestamp()"),
        "cluster");
    int n = 0;
    if (count.ok()) absl::SimpleAtoi(*count, &n);
    owned += n;
    const int64_t rss = RssKib((*cluster)->replica(i)->pid());
    rss_end += rss;
    std::printf("  %s: %d sessions leased, RSS %.1f MiB\n", id.c_str(), n,
                static_cast<double>(rss) / 1024.0);
  }
  std::printf("  leased in all: %d of %d\n", owned, sessions);
  // ListSessions through the proxy (any replica) pages through every session.
  int listed = 0;
  std::string token;
  do {
    absl::StatusOr<v1::ListSessionsResponse> page = clients[0]->ListSessions(1000, token);
    if (!page.ok()) {
      latencies.Add("ListSessions", Clock::now(), page.status());
      break;
    }
    listed += page->sessions_size();
    token = page->next_page_token();
  } while (!token.empty());
  std::printf("  ListSessions through the proxy: %d sessions\n", listed);
  std::printf("  replicas' RSS: %.1f MiB at start, %.1f MiB with every session live\n",
              static_cast<double>(rss_start) / 1024.0,
              static_cast<double>(rss_end) / 1024.0);
  int64_t errors = 0;
  {
    absl::MutexLock lock(&latencies.mu);
    std::printf("%-36s %8s %10s %10s\n", "call", "calls", "p50_ms", "p99_ms");
    for (const auto& [what, v] : latencies.ms) {
      std::printf("%-36s %8zu %10.2f %10.2f\n", what.c_str(), v.size(),
                  Percentile(v, 0.5), Percentile(v, 0.99));
    }
    for (const std::string& e : latencies.first_errors)
      std::printf("error: %s\n", e.c_str());
    errors = latencies.errors.load();
  }
  std::printf("errors: %lld\n", static_cast<long long>(errors));
  cluster->reset();
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
  return errors == 0 && listed == sessions && owned == sessions ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  absl::SetProgramUsageMessage(
      "excite-fleet [--replicas=3] [--sessions=1000] [--samples=20] [--workers=16]");
  absl::ParseCommandLine(argc, argv);
  return Run();
}
