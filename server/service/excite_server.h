#ifndef EXCITE_SERVER_SERVICE_EXCITE_SERVER_H_
#define EXCITE_SERVER_SERVICE_EXCITE_SERVER_H_

#include <chrono>
#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "grpcpp/server.h"
#include "server/service/auth.h"
#include "server/service/exploration_service.h"
#include "server/service/metrics.h"
#include "server/service/store_conversion.h"
#include "server/session/memory_budget.h"
#include "server/session/session_registry.h"
#include "server/store/session_store.h"
#include "server/web/web_view.h"

namespace excite::service {

using session::MemoryBudget;
using session::SessionRegistry;

struct ServerOptions {
  // "host:port"; port 0 picks a free one (see ExciteServer::address()).
  std::string listen = "127.0.0.1:50051";
  // Where the SQLite store lives (created if missing), unless store_url is set.
  std::string data_dir = "./.excite-data";
  // Empty: the embedded SQLite store in data_dir. "postgresql://..." (or a libpq
  // key=value string): the shared PostgreSQL store of many replicas
  // (store::PostgresStore), with store_password (never in the URL).
  std::string store_url;
  std::string store_password;
  // This replica's name in the leases it holds; empty: host name, process id
  // and a random suffix (unique per start).
  std::string replica_id;
  // Shared store: how long a lease lasts unless renewed (a dead replica's
  // sessions are served again within it), and how long an unused session stays
  // loaded (see RegistryOptions).
  std::chrono::milliseconds lease_ttl{5000};
  std::chrono::milliseconds session_idle_release{std::chrono::minutes(5)};
  // Largest message received or sent.
  int max_message_mb = 64;
  ServiceLimits limits;
  // TLS, mutual TLS and the bearer token (see auth.h). Default: plaintext, no
  // token (fine on loopback; a warning is logged on other addresses).
  SecurityOptions security;
  // HOST:PORT of the Prometheus endpoint (GET /metrics, plain HTTP, no token);
  // empty: no metrics. Port 0 picks a free one (metrics_port()).
  std::string metrics_listen;
  // The memory budget (see MemoryBudget) in bytes; 0: DefaultMemoryBudgetBytes().
  int64_t memory_budget_bytes = 0;
  // Model-based plans that may run at once, over all sessions (see
  // plan::SetConcurrentPlans; process-wide); 0: session::AvailableCores().
  int planner_workers = 0;
  // HOST:PORT of the live view (web::WebView: a page and its JSON API, with the
  // same TLS and token as the API); empty: none. Port 0 picks a free one
  // (web_port()).
  std::string web_listen;
};

// The whole server: store, session registry, ExplorationService, grpc.health.v1
// (SERVING once started) and server reflection, on one listening port. Used by
// excite-server's main and by in-process tests.
class ExciteServer {
 public:
  // Opens the store, loads the sessions, starts listening. UNAVAILABLE if the
  // address cannot be bound; the store's errors as they are.
  static absl::StatusOr<std::unique_ptr<ExciteServer>> Start(
      const ServerOptions& options);

  // Shuts down (grace 1 s) if Shutdown() was not called.
  ~ExciteServer();
  ExciteServer(const ExciteServer&) = delete;
  ExciteServer& operator=(const ExciteServer&) = delete;

  // The host of the listen address and the port actually bound.
  const std::string& host() const { return host_; }
  int port() const { return port_; }
  // The metrics endpoint's port; 0 without one.
  int metrics_port() const;
  // The live view's port; 0 without one.
  int web_port() const;
  // "host:port" (IPv6 hosts in brackets), ready to dial.
  std::string address() const;

  // Health NOT_SERVING, new RPCs get UNAVAILABLE, in-flight RPCs get `grace` to
  // finish, then the server stops (cancelling what is left). Idempotent;
  // thread-safe.
  void Shutdown(std::chrono::milliseconds grace);
  // Blocks until the server has shut down.
  void Wait();

 private:
  ExciteServer() = default;
  absl::Status StartWebView(const ServerOptions& options);

  std::string host_;
  int port_ = 0;
  std::unique_ptr<store::SessionStore> store_;
  std::unique_ptr<MemoryBudget> budget_;  // outlives registry_ (its sessions)
  ProtoStoredFormat format_;  // outlives registry_ (its sessions read with it)
  std::unique_ptr<SessionRegistry> registry_;
  std::unique_ptr<ExplorationService> service_;
  std::unique_ptr<Metrics> metrics_;  // outlives server_ (its interceptors)
  std::unique_ptr<grpc::Server> server_;
  absl::Mutex shutdown_mu_;
  bool shut_down_ ABSL_GUARDED_BY(shutdown_mu_) = false;
  // Stops before everything above (its gauges read registry_).
  std::unique_ptr<MetricsEndpoint> metrics_endpoint_;
  // Last: stops first (it calls server_ through its in-process channel).
  std::unique_ptr<web::WebView> web_view_;
};

// The store `options` name: SQLite in data_dir, or PostgreSQL at store_url.
absl::StatusOr<std::unique_ptr<store::SessionStore>> OpenStore(
    const ServerOptions& options);
// host name, process id and a random suffix: a replica name unique per start.
std::string DefaultReplicaId();

// Splits "host:port" / "[v6]:port". INVALID_ARGUMENT if malformed.
absl::Status SplitHostPort(const std::string& address, std::string* host, int* port);

}  // namespace excite::service

#endif  // EXCITE_SERVER_SERVICE_EXCITE_SERVER_H_
