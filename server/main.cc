// excite-server: the long-running gRPC service (see ../README.md).
//
// Prints exactly one line "excite-server listening on HOST:PORT" to stdout once
// it accepts RPCs (other processes parse it to find the port). SIGTERM/SIGINT:
// health NOT_SERVING, graceful shutdown (5 s grace), exit 0.

#include <pthread.h>
#include <signal.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>
#include <utility>

#include "absl/flags/flag.h"
#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "common/logging.h"
#include "common/usage.h"
#include "server/blas/blas_lock.h"
#include "server/blas/cpu_kernels.h"
#include "server/plan/plan_slots.h"
#include "server/service/auth.h"
#include "server/service/excite_server.h"

ABSL_FLAG(std::string, listen, "127.0.0.1:50051",
          "Address to listen on, HOST:PORT; port 0 picks a free port (printed).");
ABSL_FLAG(std::string, data_dir, "./.excite-data",
          "Directory of the embedded SQLite store (created if missing), unless --store "
          "names another.");
ABSL_FLAG(std::string, store, "",
          "Empty: the embedded SQLite store in --data_dir (one server). "
          "postgresql://USER@HOST:PORT/DB (or libpq key=value): a PostgreSQL database "
          "shared by many replicas, each session served by one at a time. No password "
          "here: --store_password_file, or libpq's PGPASSWORD / ~/.pgpass.");
ABSL_FLAG(std::string, store_password_file, "",
          "File holding the --store database's password (whitespace stripped).");
ABSL_FLAG(std::string, replica_id, "",
          "This replica's name in the session leases of a shared --store: must differ "
          "from every other running replica's (two live processes of one name would "
          "both own its sessions); default: host name, process id and a random "
          "suffix, new at every start.");
ABSL_FLAG(int64_t, lease_ttl_ms, 5000,
          "Shared --store: how long a session lease lasts unless renewed (renewed "
          "every third of it); a replica that dies loses its sessions this long after "
          "its last renewal.");
ABSL_FLAG(int64_t, session_idle_release_s, 300,
          "Shared --store: a session unused this long is released (memory freed, "
          "lease given up); 0: never.");
ABSL_FLAG(std::string, log_level, "info", "debug, info, warning or error.");
ABSL_FLAG(int, max_message_mb, 64, "Largest gRPC message received or sent, in MiB.");
ABSL_FLAG(int64_t, max_sessions, 10000, "Cap on the number of sessions.");
ABSL_FLAG(std::string, metrics_listen, "",
          "HOST:PORT of a Prometheus endpoint (plain HTTP GET /metrics, no token); "
          "empty: off.");
ABSL_FLAG(std::string, web_listen, "",
          "HOST:PORT of the live view: a web page of the sessions as they explore "
          "(same TLS and token as the API; open it as http(s)://HOST:PORT/#token=...); "
          "empty: off.");
ABSL_FLAG(std::string, tls_cert, "",
          "PEM server certificate (chain); with --tls_key: TLS.");
ABSL_FLAG(std::string, tls_key, "", "PEM private key of --tls_cert.");
ABSL_FLAG(std::string, tls_client_ca, "",
          "PEM CA bundle: require client certificates it signed (mutual TLS).");
ABSL_FLAG(std::string, auth_token_file, "",
          "File holding a bearer token every call must present (\"authorization: "
          "Bearer <token>\"), health checks excepted; default: $EXCITE_AUTH_TOKEN.");
ABSL_FLAG(int64_t, max_samples_per_session, 20000, "Cap on the samples of one session.");
ABSL_FLAG(int64_t, max_predict_points, 100000, "Cap on the points of one Predict call.");
ABSL_FLAG(int32_t, max_horizon, excite::service::kMaxHorizon,
          "Cap on a new session's horizon (at most 200, validation's kMaxHorizon).");
ABSL_FLAG(int64_t, memory_budget_mb, 0,
          "Memory the sessions' models may take in all (estimated peak, MiB); requests "
          "beyond it get RESOURCE_EXHAUSTED. 0: three quarters of the cgroup's memory "
          "limit or, without one, of the machine's memory.");
ABSL_FLAG(int, planner_workers, 0,
          "Plans that may run at once over all sessions (0..1024); 0: the cores this "
          "process may use (its CPU affinity and cgroup quota).");

namespace {

using excite::Log;
using excite::LogLevel;

int Run(int argc, char** argv) {
  excite::blas::RunAgainWithTheCpusBlasKernels(argv);
  excite::ParseFlags(
      argc, argv,
      "excite-server [--listen=HOST:PORT] [--data_dir=DIR] [--log_level=LEVEL]");

  absl::StatusOr<LogLevel> level = excite::ParseLogLevel(absl::GetFlag(FLAGS_log_level));
  if (!level.ok()) {
    std::fprintf(stderr, "excite-server: --log_level: %s\n",
                 std::string(level.status().message()).c_str());
    return 2;
  }
  excite::SetLogLevel(*level);
  if (const std::string core = excite::blas::OpenBlasCore(); !core.empty()) {
    Log(LogLevel::kDebug, absl::StrCat("OpenBLAS kernels: ", core));
  }
  if (absl::Status blas = excite::blas::CheckBlasRunsOnTheCallingThread(); !blas.ok()) {
    std::fprintf(stderr, "excite-server: %s\n", std::string(blas.message()).c_str());
    return 2;
  }

  // Block the signals in every thread (gRPC's threads inherit the mask); one
  // thread receives them with sigwait, so no work happens in a signal handler.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  excite::service::ServerOptions options;
  options.listen = absl::GetFlag(FLAGS_listen);
  options.data_dir = absl::GetFlag(FLAGS_data_dir);
  options.store_url = absl::GetFlag(FLAGS_store);
  if (const std::string path = absl::GetFlag(FLAGS_store_password_file); !path.empty()) {
    absl::StatusOr<std::string> password = excite::service::ReadSecretFile(path);
    if (!password.ok()) {
      std::fprintf(stderr, "excite-server: --store_password_file: %s\n",
                   std::string(password.status().message()).c_str());
      return 2;
    }
    options.store_password = *std::move(password);
  }
  options.replica_id = absl::GetFlag(FLAGS_replica_id);
  options.lease_ttl = std::chrono::milliseconds(absl::GetFlag(FLAGS_lease_ttl_ms));
  options.session_idle_release =
      std::chrono::seconds(absl::GetFlag(FLAGS_session_idle_release_s));
  options.max_message_mb = absl::GetFlag(FLAGS_max_message_mb);
  options.limits.max_sessions = absl::GetFlag(FLAGS_max_sessions);
  options.limits.max_samples_per_session = absl::GetFlag(FLAGS_max_samples_per_session);
  options.limits.max_predict_points = absl::GetFlag(FLAGS_max_predict_points);
  options.limits.max_horizon = absl::GetFlag(FLAGS_max_horizon);
  options.metrics_listen = absl::GetFlag(FLAGS_metrics_listen);
  options.web_listen = absl::GetFlag(FLAGS_web_listen);
  options.memory_budget_bytes =
      absl::GetFlag(FLAGS_memory_budget_mb) * (int64_t{1} << 20);
  options.planner_workers = absl::GetFlag(FLAGS_planner_workers);
  options.security.tls_cert_file = absl::GetFlag(FLAGS_tls_cert);
  options.security.tls_key_file = absl::GetFlag(FLAGS_tls_key);
  options.security.tls_client_ca_file = absl::GetFlag(FLAGS_tls_client_ca);
  if (const std::string path = absl::GetFlag(FLAGS_auth_token_file); !path.empty()) {
    absl::StatusOr<std::string> token = excite::service::ReadSecretFile(path);
    if (!token.ok()) {
      std::fprintf(stderr, "excite-server: --auth_token_file: %s\n",
                   std::string(token.status().message()).c_str());
      return 2;
    }
    options.security.auth_token = *std::move(token);
  } else if (const char* env = std::getenv("EXCITE_AUTH_TOKEN"); env != nullptr) {
    // Set but empty (or blank) is a mistake, not a wish for no authentication.
    options.security.auth_token = std::string(absl::StripAsciiWhitespace(env));
    if (options.security.auth_token.empty()) {
      std::fprintf(stderr,
                   "excite-server: EXCITE_AUTH_TOKEN is set but empty; set a token, or "
                   "unset it to run without one\n");
      return 2;
    }
  }
  absl::StatusOr<std::unique_ptr<excite::service::ExciteServer>> server =
      excite::service::ExciteServer::Start(options);
  if (!server.ok()) {
    std::fprintf(stderr, "excite-server: %s\n", server.status().ToString().c_str());
    return 1;
  }

  Log(LogLevel::kInfo, absl::StrCat("plans up to ", excite::plan::ConcurrentPlans(),
                                    " sessions at once (--planner_workers)"));
  if ((*server)->metrics_port() > 0) {
    Log(LogLevel::kInfo,
        absl::StrCat("metrics on port ", (*server)->metrics_port(), " (GET /metrics)"));
  }
  std::thread signal_thread([&signals, s = server->get()]() {
    int signal = 0;
    if (sigwait(&signals, &signal) != 0) return;
    Log(LogLevel::kInfo,
        absl::StrCat("received ", signal == SIGTERM ? "SIGTERM" : "SIGINT",
                     ": draining (grace 5 s)"));
    s->Shutdown(std::chrono::seconds(5));
  });

  std::printf("excite-server listening on %s\n", (*server)->address().c_str());
  std::fflush(stdout);

  (*server)->Wait();
  signal_thread.join();
  server->reset();
  Log(LogLevel::kInfo, "stopped");
  return 0;
}

}  // namespace

int main(int argc, char** argv) { return Run(argc, argv); }
