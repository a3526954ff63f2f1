// excite-load: starts excite-server on 127.0.0.1 (a temp data dir) or, with
// --replicas=N, N replicas on a PostgreSQL server behind HAProxy
// (tests/support/local_cluster.h), runs --sessions sessions at once for
// --seconds, each repeating PlanInputs from its pendulum's state, applying the
// inputs, streaming the transitions (AddData) and calling Predict on a batch of
// points. Prints, per method, calls, errors, p50 and p99 latency, plans per
// second, and the servers' RSS at start and end. Exit 1 on any error.

#include <signal.h>
#include <stdlib.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
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
#include "tests/support/child_process.h"
#include "tests/support/local_cluster.h"

ABSL_FLAG(int, sessions, 32, "Concurrent sessions (1..256).");
ABSL_FLAG(int, seconds, 60, "Duration of the load in seconds (1..600).");
ABSL_FLAG(int, max_samples, 300, "Samples per session after which AddData stops.");
ABSL_FLAG(std::string, strategy, "STRATEGY_REC", "Strategy of every session.");
ABSL_FLAG(std::string, server_binary, EXCITE_SERVER_BINARY, "excite-server to start.");
ABSL_FLAG(int, replicas, 0,
          "0: one excite-server on SQLite. N >= 1: N replicas on one PostgreSQL "
          "server behind HAProxy (deploy/haproxy/haproxy.cfg), as compose.scale.yaml.");
ABSL_FLAG(std::string, haproxy_config, EXCITE_SOURCE_DIR "/deploy/haproxy/haproxy.cfg",
          "--replicas: the HAProxy configuration to adapt.");

namespace {

using excite::bench::Percentile;
using excite::bench::RssKib;

using Clock = std::chrono::steady_clock;
using excite::client::ExciteClient;
using excite::testing::ChildProcess;
using excite::testing::LocalCluster;
using excite::testing::LocalClusterOptions;
namespace v1 = excite::v1;

constexpr char kConfig[] = R"pb(
  state_dim: 2
  input_dim: 1
  input_bounds { lower: -3 upper: 3 }
  state_bounds { lower: -3.2 upper: 3.2 }
  state_bounds { lower: -8 upper: 8 }
  noise { variance: 1e-4 fit: true }
  kernel { fit: true restarts: 1 max_iterations: 40 }
  horizon: 5
  planner { max_iterations: 30 time_budget_s: 5 }
)pb";

std::array<double, 2> PendulumStep(const std::array<double, 2>& x, double u) {
  constexpr double kDt = 0.05;
  constexpr int kSub = 5;
  std::array<double, 2> s = x;
  auto f = [u](const std::array<double, 2>& z) {
    return std::array<double, 2>{z[1], -9.81 * std::sin(z[0]) - 0.1 * z[1] + u};
  };
  const double h = kDt / kSub;
  for (int i = 0; i < kSub; ++i) {
    const auto k1 = f(s);
    const auto k2 = f({s[0] + 0.5 * h * k1[0], s[1] + 0.5 * h * k1[1]});
    const auto k3 = f({s[0] + 0.5 * h * k2[0], s[1] + 0.5 * h * k2[1]});
    const auto k4 = f({s[0] + h * k3[0], s[1] + h * k3[1]});
    for (int j = 0; j < 2; ++j) s[j] += h / 6 * (k1[j] + 2 * k2[j] + 2 * k3[j] + k4[j]);
  }
  return s;
}

struct Results {
  absl::Mutex mu;
  std::map<std::string, std::vector<double>> latencies_ms ABSL_GUARDED_BY(mu);
  std::map<std::string, int64_t> errors ABSL_GUARDED_BY(mu);
  std::vector<std::string> first_errors ABSL_GUARDED_BY(mu);

  void Add(const std::string& method, Clock::time_point start, const absl::Status& s) {
    const double ms =
        std::chrono::duration<double, std::milli>(Clock::now() - start).count();
    absl::MutexLock lock(&mu);
    latencies_ms[method].push_back(ms);
    if (!s.ok()) {
      ++errors[method];
      if (first_errors.size() < 10) first_errors.push_back(method + ": " + s.ToString());
    }
  }
};

void RunSession(const std::string& address, const v1::SessionConfig& config, int index,
                Clock::time_point end, int max_samples, Results* results) {
  std::unique_ptr<ExciteClient> client = ExciteClient::Connect(address);
  Clock::time_point start = Clock::now();
  absl::StatusOr<v1::Session> session =
      client->CreateSession(config, absl::StrCat("load-", index));
  results->Add("CreateSession", start, session.status());
  if (!session.ok()) return;
  std::mt19937 rng(static_cast<uint32_t>(index + 1));
  std::uniform_real_distribution<double> unit(-1, 1);
  std::array<double, 2> x{0.1 * unit(rng), 0};
  int64_t sequence = 0;
  // Warm-up as a plant would do it: 10 random inputs (models need >= 2 samples).
  std::vector<v1::Transition> warmup;
  for (int i = 0; i < 10; ++i) {
    const double u = 3 * unit(rng);
    const std::array<double, 2> y = PendulumStep(x, u);
    v1::Transition t;
    t.add_state(x[0]);
    t.add_state(x[1]);
    t.add_input(u);
    t.add_next_state(y[0]);
    t.add_next_state(y[1]);
    t.set_sequence(sequence++);
    warmup.push_back(t);
    x = y;
  }
  start = Clock::now();
  results->Add("AddData", start, client->AddData(session->name(), {warmup}).status());
  while (Clock::now() < end) {
    start = Clock::now();
    absl::StatusOr<v1::PlanInputsResponse> plan =
        client->PlanInputs(session->name(), {x[0], x[1]});
    results->Add("PlanInputs", start, plan.status());
    std::vector<double> inputs;
    if (plan.ok()) {
      const int n = std::max(1, std::min<int>(plan->apply_count(), plan->inputs_size()));
      inputs.assign(plan->inputs().begin(), plan->inputs().begin() + n);
    }
    if (inputs.empty()) inputs = {3 * unit(rng)};
    std::vector<v1::Transition> batch;
    for (double u : inputs) {
      const std::array<double, 2> y = PendulumStep(x, u);
      v1::Transition t;
      t.add_state(x[0]);
      t.add_state(x[1]);
      t.add_input(u);
      t.add_next_state(y[0] + 0.01 * unit(rng));
      t.add_next_state(y[1] + 0.01 * unit(rng));
      t.set_sequence(sequence++);
      batch.push_back(t);
      x = y;
    }
    if (sequence <= max_samples) {
      start = Clock::now();
      results->Add("AddData", start, client->AddData(session->name(), {batch}).status());
    }
    v1::PredictRequest predict;
    predict.set_session(session->name());
    for (int i = 0; i < 16; ++i) {
      predict.add_inputs(3.2 * unit(rng));
      predict.add_inputs(8 * unit(rng));
      predict.add_inputs(3 * unit(rng));
    }
    start = Clock::now();
    results->Add("Predict", start, client->Predict(predict).status());
  }
}

int Run() {
  const int sessions = absl::GetFlag(FLAGS_sessions);
  const int seconds = absl::GetFlag(FLAGS_seconds);
  if (sessions < 1 || sessions > 256 || seconds < 1 || seconds > 600) {
    std::fprintf(stderr, "excite-load: --sessions in [1, 256], --seconds in [1, 600]\n");
    return 2;
  }
  absl::StatusOr<v1::SessionConfig> config =
      excite::service::ParseSessionConfigText(kConfig);
  v1::Strategy strategy;
  if (!config.ok() || !v1::Strategy_Parse(absl::GetFlag(FLAGS_strategy), &strategy)) {
    std::fprintf(stderr, "excite-load: bad config or --strategy\n");
    return 2;
  }
  config->set_strategy(strategy);

  std::string dir = (std::filesystem::temp_directory_path() / "excite-load-XXXXXX");
  if (mkdtemp(dir.data()) == nullptr) return 1;
  const std::string binary = absl::GetFlag(FLAGS_server_binary);
  const int replicas = absl::GetFlag(FLAGS_replicas);
  std::unique_ptr<ChildProcess> single;
  std::unique_ptr<LocalCluster> cluster;
  std::string address;
  if (replicas <= 0) {
    address = absl::StrCat("127.0.0.1:", excite::testing::FreeLoopbackPort());
    single = std::make_unique<ChildProcess>(
        std::vector<std::string>{binary, "--listen=" + address,
                                 "--data_dir=" + dir + "/data", "--log_level=warning"},
        dir + "/server.log");
    const Clock::time_point give_up = Clock::now() + std::chrono::seconds(30);
    while (single->Log().find("listening on") == std::string::npos) {
      if (!single->running() || Clock::now() > give_up) {
        std::fprintf(stderr, "excite-load: server did not start:\n%s\n",
                     single->Log().c_str());
        return 1;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
  } else {
    LocalClusterOptions options;
    options.replicas = replicas;
    options.server_binary = binary;
    options.haproxy_config = absl::GetFlag(FLAGS_haproxy_config);
    options.server_flags = {"--log_level=warning"};
    options.dir = dir;
    absl::StatusOr<std::unique_ptr<LocalCluster>> started = LocalCluster::Start(options);
    if (!started.ok()) {
      std::fprintf(stderr, "excite-load: %s\n", started.status().ToString().c_str());
      return 1;
    }
    cluster = *std::move(started);
    address = cluster->proxy_address();
  }
  const auto server_rss = [&]() {
    if (single != nullptr) return RssKib(single->pid());
    int64_t total = 0;
    for (int i = 0; i < cluster->replicas(); ++i)
      total += RssKib(cluster->replica(i)->pid());
    return total;
  };
  const int64_t rss_start = server_rss();
  Results results;
  const Clock::time_point end = Clock::now() + std::chrono::seconds(seconds);
  std::vector<std::thread> threads;
  for (int i = 0; i < sessions; ++i) {
    threads.emplace_back(RunSession, address, *config, i, end,
                         absl::GetFlag(FLAGS_max_samples), &results);
  }
  for (std::thread& t : threads) t.join();
  const double elapsed =
      std::chrono::duration<double>(Clock::now() - end).count() + seconds;
  const int64_t rss_end = server_rss();
  int result = 1;
  {
    absl::MutexLock lock(&results.mu);
    int64_t errors = 0;
    std::printf("excite-load: %d sessions, %.1f s, strategy %s, %s\n", sessions, elapsed,
                absl::GetFlag(FLAGS_strategy).c_str(),
                replicas <= 0
                    ? "one server (SQLite)"
                    : absl::StrCat(replicas, " replicas (PostgreSQL, HAProxy)").c_str());
    std::printf("%-14s %8s %7s %10s %10s\n", "method", "calls", "errors", "p50_ms",
                "p99_ms");
    for (const auto& [method, v] : results.latencies_ms) {
      const int64_t e = results.errors[method];
      errors += e;
      std::printf("%-14s %8zu %7lld %10.2f %10.2f\n", method.c_str(), v.size(),
                  static_cast<long long>(e), Percentile(v, 0.5), Percentile(v, 0.99));
    }
    std::printf("plans per second: %.1f\n",
                static_cast<double>(results.latencies_ms["PlanInputs"].size()) / elapsed);
    for (const std::string& e : results.first_errors) {
      std::printf("error: %s\n", e.c_str());
    }
    std::printf("server RSS (all replicas): start %lld KiB, end %lld KiB\n",
                static_cast<long long>(rss_start), static_cast<long long>(rss_end));
    std::printf("errors: %lld\n", static_cast<long long>(errors));
    result = errors == 0 ? 0 : 1;
  }
  cluster.reset();
  if (single != nullptr) {
    single->Signal(SIGTERM);
    single->Wait(std::chrono::seconds(10));
    single.reset();
  }
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
  return result;
}

}  // namespace

int main(int argc, char** argv) {
  absl::SetProgramUsageMessage(
      "excite-load [--sessions=32] [--seconds=60] [--max_samples=300] "
      "[--strategy=STRATEGY_REC] [--replicas=N]");
  absl::ParseCommandLine(argc, argv);
  return Run();
}
