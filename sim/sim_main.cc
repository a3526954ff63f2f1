// excite-sim: runs one active-learning exploration of a simulated plant against an
// excite-server and writes a JSON summary.
//
//   excite-sim --server=127.0.0.1:50051 --config=sim/configs/pendulum.textproto
//              --strategy=pa --samples=300 --seed=3 --summary=/tmp/pa.json

#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdint>
#include <fstream>
#include <iostream>
#include <memory>
#include <string>

#include "absl/flags/flag.h"
#include "absl/strings/str_format.h"
#include "client/connection_flags.h"
#include "client/excite_client.h"
#include "common/usage.h"
#include "server/service/config_text.h"
#include "server/service/strategy_names.h"
#include "sim/exploration_run.h"
#include "sim/plants/plant_factory.h"
#include "sim/run_summary.h"
#include "sim/sim_config.h"

ABSL_FLAG(std::string, server, "127.0.0.1:50051", "excite-server address, HOST:PORT");
ABSL_FLAG(std::string, config, "", "SimConfig textproto file (required)");
ABSL_FLAG(std::string, strategy, "",
          "rec, pa, greedy, sep, mi, roi, optimistic, auto, prbs, chirp or random (any "
          "case, or the STRATEGY_ name); overrides the config's. Or uniform: the "
          "idealised reference design, every (x, u) drawn "
          "uniformly from the region x the input bounds (no plant can follow it)");
ABSL_FLAG(int32_t, samples, 0, "transitions to collect; 0 keeps the config's");
ABSL_FLAG(int64_t, seed, -1,
          "seed of the measurement noise and of the session; -1 keeps the config's "
          "session.seed");
ABSL_FLAG(std::string, session_override, "",
          "SessionConfig textproto merged over the config's session before the other "
          "flags, e.g. 'refit { growth: 0.05 } sparse { above_samples: 0 }'");
ABSL_FLAG(std::string, summary, "", "write the JSON run summary to this file");
ABSL_FLAG(std::string, trajectory, "",
          "write every stored transition to this CSV file (x, u, x_next, sequence: "
          "the layout excite add reads)");
ABSL_FLAG(bool, keep_session, false,
          "keep the session on the server at the end (also after a failure or Ctrl-C)");
ABSL_FLAG(bool, replace, false,
          "with --session_id: delete a session of that id that exists already and "
          "start anew (default: ALREADY_EXISTS ends the run)");
ABSL_FLAG(bool, resume, false,
          "with --session_id: continue that session (kept, say, with --keep_session "
          "before a Ctrl-C) until it holds --samples: its samples stay, the plant starts "
          "from its last stored state, the session's stored config plans; the session is "
          "kept at the end");
ABSL_FLAG(double, realtime_hz, 0.0,
          "> 0: a real-time plant stepping at this rate on the wall clock, never "
          "waiting for the server; plans are computed beside it from the state after "
          "the inputs it applies meanwhile (pending_inputs), and a tick no plan covers "
          "holds the last input. 0: lock-step (the plant waits for each plan)");
ABSL_FLAG(std::string, session_id, "", "session id to ask for; empty: server's choice");
ABSL_FLAG(int32_t, connect_timeout_s, 10, "how long to wait for the server to be ready");
ABSL_FLAG(int32_t, retry_unavailable_s, 30,
          "how long a call that fails with UNAVAILABLE (a replica restarting, a session "
          "moving between replicas) is retried before the run fails; 0: never");
ABSL_FLAG(int32_t, data_deadline_s, 10,
          "deadline of one AddData attempt (storing one step's transitions takes "
          "milliseconds); an attempt past it is retried within --retry_unavailable_s "
          "with the same sequence numbers");

namespace excite::sim {
namespace {

int Fail(const absl::Status& status) {
  std::cerr << "excite-sim: " << status.message() << " ("
            << absl::StatusCodeToString(status.code()) << ")\n";
  return 1;
}

// Ctrl-C (SIGINT) or SIGTERM: the run stops after its current step, deletes its
// session unless --keep_session, and says so; a second one ends the process.
std::atomic<bool> interrupted{false};

void OnInterrupt(int signal_number) {
  interrupted.store(true);
  std::signal(signal_number, SIG_DFL);
}

int Main() {
  const std::string config_path = absl::GetFlag(FLAGS_config);
  if (config_path.empty()) {
    return Fail(
        absl::InvalidArgumentError("--config is required (a SimConfig textproto)"));
  }
  absl::StatusOr<v1::SimConfig> config = LoadSimConfig(config_path);
  if (!config.ok()) return Fail(config.status());

  if (const std::string text = absl::GetFlag(FLAGS_session_override); !text.empty()) {
    absl::StatusOr<v1::SessionConfig> patch = service::ParseSessionConfigText(text);
    if (!patch.ok()) {
      return Fail(absl::InvalidArgumentError(
          absl::StrCat("--session_override: ", patch.status().message())));
    }
    config->mutable_session()->MergeFrom(*patch);
  }
  SimOverrides overrides;
  const bool uniform_design = absl::GetFlag(FLAGS_strategy) == "uniform";
  if (const std::string name = absl::GetFlag(FLAGS_strategy);
      !name.empty() && !uniform_design) {
    absl::StatusOr<v1::Strategy> strategy = service::ParseStrategyName(name);
    if (!strategy.ok()) return Fail(strategy.status());
    overrides.strategy = *strategy;
  }
  if (const int32_t samples = absl::GetFlag(FLAGS_samples); samples != 0) {
    if (samples < 0)
      return Fail(absl::InvalidArgumentError("--samples must be positive"));
    overrides.samples = samples;
  }
  if (const int64_t seed = absl::GetFlag(FLAGS_seed); seed >= 0) {
    overrides.seed = static_cast<uint64_t>(seed);
  }
  ApplyOverrides(overrides, &*config);
  if (absl::Status s = ValidateSimConfig(*config); !s.ok()) {
    return Fail(absl::InvalidArgumentError(absl::StrCat(config_path, ": ", s.message())));
  }
  absl::StatusOr<std::unique_ptr<Plant>> plant = MakePlant(config->plant());
  if (!plant.ok()) return Fail(plant.status());

  const std::string server = absl::GetFlag(FLAGS_server);
  client::ClientOptions client_options;
  if (absl::Status s = client::ApplyConnectionFlags(&client_options); !s.ok()) {
    return Fail(s);
  }
  client_options.retry_unavailable =
      std::chrono::seconds(std::max(0, absl::GetFlag(FLAGS_retry_unavailable_s)));
  client_options.data_deadline =
      std::chrono::seconds(std::max(1, absl::GetFlag(FLAGS_data_deadline_s)));
  std::unique_ptr<client::ExciteClient> client =
      client::ExciteClient::Connect(server, client_options);
  if (absl::Status s = client->WaitForReady(
          std::chrono::seconds(absl::GetFlag(FLAGS_connect_timeout_s)));
      !s.ok()) {
    return Fail(absl::UnavailableError(
        absl::StrCat("cannot reach excite-server at ", server, ": ", s.message())));
  }

  std::cout << absl::StrFormat("excite-sim: %s, strategy %s, %d samples, server %s\n",
                               config->system(),
                               uniform_design ? "uniform"
                                              : service::StrategyShortName(
                                                    config->session().strategy()),
                               config->samples(), server)
            << std::flush;
  ExplorationOptions options;
  options.session_id = absl::GetFlag(FLAGS_session_id);
  options.keep_session = absl::GetFlag(FLAGS_keep_session);
  options.replace_session = absl::GetFlag(FLAGS_replace);
  options.resume_session = absl::GetFlag(FLAGS_resume);
  options.interrupted = &interrupted;
  std::signal(SIGINT, OnInterrupt);
  std::signal(SIGTERM, OnInterrupt);
  options.log = &std::cout;
  options.uniform_design = uniform_design;
  options.realtime_hz = absl::GetFlag(FLAGS_realtime_hz);
  if (!(options.realtime_hz >= 0.0 && options.realtime_hz <= 10000.0) ||
      (options.realtime_hz > 0 && uniform_design)) {
    std::cerr << "excite-sim: --realtime_hz must be in [0, 10000] (0: lock-step), and "
                 "the uniform design has no clock\n";
    return 2;
  }
  std::ofstream trajectory;
  const std::string trajectory_path = absl::GetFlag(FLAGS_trajectory);
  if (!trajectory_path.empty()) {
    trajectory.open(trajectory_path);
    if (!trajectory) {
      std::cerr << "excite-sim: cannot write --trajectory=" << trajectory_path << "\n";
      return 1;
    }
    options.trajectory = &trajectory;
  }
  absl::StatusOr<RunSummary> summary = RunExploration(*client, **plant, *config, options);
  if (!summary.ok()) return Fail(summary.status());
  if (!trajectory_path.empty()) {
    trajectory.close();
    if (!trajectory) {
      std::cerr << "excite-sim: writing --trajectory=" << trajectory_path << " failed\n";
      return 1;
    }
    std::cout << "trajectory written to " << trajectory_path
              << " (plot: sim/plot_trajectory.py " << trajectory_path << ")\n";
  }

  std::cout << absl::StrFormat(
      "final rmse %.4f coverage marginal %.3f joint %s plan_ms_p50 %.1f wall_s %.1f\n",
      summary->final_rmse, summary->coverage_marginal,
      summary->coverage_joint.has_value()
          ? absl::StrFormat("%.3f", *summary->coverage_joint)
          : "n/a",
      summary->plan_ms_p50, summary->wall_s);
  if (summary->state_names.size() == summary->final_rmse_per_dimension.size() &&
      !summary->state_names.empty()) {
    std::string line = "final rmse per dimension:";
    for (size_t j = 0; j < summary->state_names.size(); ++j) {
      const std::string unit =
          j < summary->state_units.size() ? summary->state_units[j] : std::string();
      absl::StrAppend(&line, j == 0 ? " " : ", ", summary->state_names[j], " ",
                      absl::StrFormat("%.4g", summary->final_rmse_per_dimension[j]),
                      unit.empty() ? "" : " ", unit);
    }
    std::cout << line << "\n";
  }
  if (const RealtimeStats& rt = summary->realtime; rt.hz > 0) {
    const int64_t ticks = rt.ticks_from_plan + rt.ticks_fell_back;
    std::cout << absl::StrFormat(
        "real time at %g Hz: %d of %d ticks from a plan, %d fell back (held the last "
        "input, %.1f %%); %d plans late, %d ticks overran; plan_ms p50 %.1f p90 %.1f "
        "p99 %.1f\n",
        rt.hz, rt.ticks_from_plan, ticks, rt.ticks_fell_back,
        ticks > 0 ? 100.0 * static_cast<double>(rt.ticks_fell_back) / ticks : 0.0,
        rt.late_plans, rt.overruns, summary->plan_ms_p50, summary->plan_ms_p90,
        summary->plan_ms_p99);
  }
  if (summary->left_safe_box.has_value()) {
    std::cout << absl::StrFormat("visited states outside the safe box: %.1f %%\n",
                                 100.0 * *summary->left_safe_box);
  }
  if (const std::string path = absl::GetFlag(FLAGS_summary); !path.empty()) {
    if (absl::Status s = WriteRunSummary(*summary, path); !s.ok()) return Fail(s);
    std::cout << "summary written to " << path << "\n";
  }
  if (options.keep_session || options.resume_session) {
    std::cout << "session kept: " << summary->session << "\n";
  }
  return 0;
}

}  // namespace
}  // namespace excite::sim

int main(int argc, char** argv) {
  excite::ParseFlags(
      argc, argv,
      "Runs one exploration of a simulated plant against excite-server.\n"
      "  excite-sim --config=sim/configs/pendulum.textproto [--server=HOST:PORT]\n"
      "             [--strategy=NAME] [--samples=N] [--seed=S] "
      "[--summary=FILE]");
  return excite::sim::Main();
}
