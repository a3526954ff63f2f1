#include "server/service/excite_server.h"

#include <unistd.h>

#include <cstdio>
#include <utility>
#include <vector>

#include "absl/random/random.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/time/time.h"
#include "common/logging.h"
#include "grpcpp/ext/proto_server_reflection_plugin.h"
#include "grpcpp/health_check_service_interface.h"
#include "grpcpp/security/server_credentials.h"
#include "grpcpp/server_builder.h"
#include "server/plan/plan_slots.h"
#include "server/service/malformed_request_interceptor.h"
#include "server/session/machine_limits.h"
#include "server/store/postgres_store.h"
#include "server/store/sqlite_store.h"

namespace excite::service {
namespace {

// More would only queue more plans on the cores (plan::SetConcurrentPlans).
constexpr int kMaxPlannerWorkers = 1024;

}  // namespace

absl::Status SplitHostPort(const std::string& address, std::string* host, int* port) {
  const size_t colon = address.rfind(':');
  if (colon == std::string::npos || colon == 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("listen address \"", address, "\" is not HOST:PORT"));
  }
  std::string h = address.substr(0, colon);
  if (h.size() >= 2 && h.front() == '[' && h.back() == ']') h = h.substr(1, h.size() - 2);
  int p = 0;
  if (!absl::SimpleAtoi(address.substr(colon + 1), &p) || p < 0 || p > 65535) {
    return absl::InvalidArgumentError(
        absl::StrCat("listen address \"", address, "\": bad port"));
  }
  *host = std::move(h);
  *port = p;
  return absl::OkStatus();
}

absl::StatusOr<std::unique_ptr<store::SessionStore>> OpenStore(
    const ServerOptions& options) {
  if (options.store_url.empty()) {
    absl::StatusOr<std::unique_ptr<store::SqliteStore>> sqlite =
        store::SqliteStore::Open(options.data_dir);
    if (!sqlite.ok()) return sqlite.status();
    return std::unique_ptr<store::SessionStore>(*std::move(sqlite));
  }
  store::PostgresStoreOptions postgres;
  postgres.url = options.store_url;
  postgres.password = options.store_password;
  postgres.owner = options.replica_id.empty() ? DefaultReplicaId() : options.replica_id;
  postgres.lease_ttl = options.lease_ttl;
  absl::StatusOr<std::unique_ptr<store::PostgresStore>> opened =
      store::PostgresStore::Open(postgres);
  if (!opened.ok()) return opened.status();
  Log(LogLevel::kInfo,
      absl::StrCat("replica ", postgres.owner, " on ", (*opened)->location()));
  return std::unique_ptr<store::SessionStore>(*std::move(opened));
}

std::string DefaultReplicaId() {
  char host[256] = {};
  if (gethostname(host, sizeof(host) - 1) != 0 || host[0] == '\0') {
    std::snprintf(host, sizeof(host), "excite");
  }
  absl::BitGen random;
  static constexpr char kAlphabet[] = "0123456789abcdefghijklmnopqrstuvwxyz";
  std::string suffix;
  for (int i = 0; i < 6; ++i) {
    suffix.push_back(kAlphabet[absl::Uniform<size_t>(random, 0, sizeof(kAlphabet) - 1)]);
  }
  return absl::StrCat(host, "-", getpid(), "-", suffix);
}

absl::StatusOr<std::unique_ptr<ExciteServer>> ExciteServer::Start(
    const ServerOptions& options) {
  std::unique_ptr<ExciteServer> server(new ExciteServer());
  int requested_port = 0;
  if (absl::Status s = SplitHostPort(options.listen, &server->host_, &requested_port);
      !s.ok()) {
    return s;
  }
  if (options.max_message_mb < 1 || options.max_message_mb > 2047) {
    return absl::InvalidArgumentError(absl::StrCat(
        "max_message_mb must be in [1, 2047], got ", options.max_message_mb));
  }
  absl::StatusOr<std::unique_ptr<store::SessionStore>> store = OpenStore(options);
  if (!store.ok()) return store.status();
  server->store_ = *std::move(store);
  if (!options.metrics_listen.empty()) server->metrics_ = std::make_unique<Metrics>();
  if (options.memory_budget_bytes < 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("memory budget must be >= 0 (0: the default), got ",
                     options.memory_budget_bytes));
  }
  if (options.planner_workers < 0 || options.planner_workers > kMaxPlannerWorkers) {
    return absl::InvalidArgumentError(absl::StrCat(
        "planner_workers must be in [0, ", kMaxPlannerWorkers,
        "] (0: the cores this process may use), got ", options.planner_workers));
  }
  plan::SetConcurrentPlans(options.planner_workers > 0 ? options.planner_workers
                                                       : session::AvailableCores());
  server->budget_ = std::make_unique<MemoryBudget>(
      options.memory_budget_bytes > 0 ? options.memory_budget_bytes
                                      : session::DefaultMemoryBudgetBytes());
  session::RegistryOptions registry_options;
  registry_options.format = &server->format_;
  registry_options.max_sessions = options.limits.max_sessions;
  registry_options.metrics = server->metrics_.get();
  registry_options.budget = server->budget_.get();
  registry_options.lease_ttl = options.lease_ttl;
  registry_options.idle_release = options.session_idle_release;
  absl::StatusOr<std::unique_ptr<SessionRegistry>> registry =
      SessionRegistry::Load(server->store_.get(), registry_options);
  if (!registry.ok()) return registry.status();
  server->registry_ = *std::move(registry);
  ServiceLimits limits = options.limits;
  limits.max_message_bytes = int64_t{options.max_message_mb} * 1024 * 1024;
  server->service_ =
      std::make_unique<ExplorationService>(server->registry_.get(), limits);

  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  grpc::ServerBuilder builder;
  int bound_port = 0;
  absl::StatusOr<std::shared_ptr<grpc::ServerCredentials>> credentials =
      MakeServerCredentials(options.security, server->host_);
  if (!credentials.ok()) return credentials.status();
  if (!IsLoopbackHost(server->host_) && options.security.tls_cert_file.empty() &&
      options.security.auth_token.empty()) {
    Log(LogLevel::kWarning,
        absl::StrCat("listening on ", server->host_,
                     " without TLS and without a token: anyone who can reach the port "
                     "can use it (see --tls_cert, --tls_key, --auth_token_file)"));
  }
  builder.AddListeningPort(options.listen, *credentials, &bound_port);
  const int max_bytes = options.max_message_mb * 1024 * 1024;
  builder.SetMaxReceiveMessageSize(max_bytes);
  builder.SetMaxSendMessageSize(max_bytes);
  // Never share a port with another process (gRPC enables SO_REUSEPORT otherwise).
  builder.AddChannelArgument(GRPC_ARG_ALLOW_REUSEPORT, 0);
  builder.RegisterService(server->service_.get());
  std::vector<std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface>>
      interceptors;
  // First: the metrics see the status it sends.
  interceptors.push_back(MakeMalformedRequestInterceptorFactory());
  if (server->metrics_ != nullptr) {
    interceptors.push_back(MakeMetricsInterceptorFactory(server->metrics_.get()));
  }
  builder.experimental().SetInterceptorCreators(std::move(interceptors));
  server->server_ = builder.BuildAndStart();
  if (server->server_ == nullptr || bound_port == 0) {
    return absl::UnavailableError(absl::StrCat("cannot listen on ", options.listen));
  }
  server->port_ = bound_port;
  if (server->metrics_ != nullptr) {
    SessionRegistry* sessions = server->registry_.get();
    server->metrics_->AddGauge(
        "excite_sessions", "Sessions held (loaded by this replica).",
        [sessions]() { return static_cast<double>(sessions->size()); });
    server->metrics_->AddGauge(
        "excite_samples", "Samples held over the sessions loaded by this replica.",
        [sessions]() { return static_cast<double>(sessions->loaded_samples()); });
    MemoryBudget* budget = server->budget_.get();
    server->metrics_->AddGauge(
        "excite_memory_estimate_bytes",
        "Estimated peak memory of all sessions' models, as the memory budget counts it.",
        [budget]() { return static_cast<double>(budget->used()); });
    server->metrics_->AddGauge(
        "excite_memory_budget_bytes", "The memory budget.",
        [budget]() { return static_cast<double>(budget->limit()); });
    server->metrics_->AddGauge(
        "excite_planner_workers", "Plans that may run at once (--planner_workers).",
        []() { return static_cast<double>(plan::ConcurrentPlans()); });
    absl::StatusOr<std::unique_ptr<MetricsEndpoint>> endpoint =
        MetricsEndpoint::Start(options.metrics_listen, server->metrics_.get());
    if (!endpoint.ok()) return endpoint.status();
    server->metrics_endpoint_ = *std::move(endpoint);
    std::string metrics_host;
    int metrics_port = 0;
    if (SplitHostPort(options.metrics_listen, &metrics_host, &metrics_port).ok() &&
        !IsLoopbackHost(metrics_host)) {
      Log(LogLevel::kWarning,
          absl::StrCat("metrics on ", options.metrics_listen,
                       ": plain HTTP without a token, readable by anyone who can reach "
                       "the port (session counts, timings); listen on 127.0.0.1 unless "
                       "a network policy restricts it"));
    }
  }
  if (!options.web_listen.empty()) {
    if (absl::Status s = server->StartWebView(options); !s.ok()) return s;
  }
  if (grpc::HealthCheckServiceInterface* health =
          server->server_->GetHealthCheckService()) {
    health->SetServingStatus(true);
  }
  Log(LogLevel::kInfo,
      absl::StrCat("serving ", server->registry_->size(), " sessions from ",
                   server->store_->location(), "; memory budget ",
                   session::FormatBytes(server->budget_->limit()), ", ",
                   session::FormatBytes(server->budget_->used()), " in use"));
  if (server->budget_->used() > server->budget_->limit()) {
    Log(LogLevel::kWarning,
        "the stored sessions exceed the memory budget: they are served, but none may "
        "grow until enough is deleted (or --memory_budget_mb is raised)");
  }
  return server;
}

ExciteServer::~ExciteServer() {
  Shutdown(std::chrono::seconds(1));
  if (server_ != nullptr) server_->Wait();
}

int ExciteServer::metrics_port() const {
  return metrics_endpoint_ != nullptr ? metrics_endpoint_->port() : 0;
}

absl::Status ExciteServer::StartWebView(const ServerOptions& options) {
  std::string host;
  int port = 0;
  if (absl::Status s = SplitHostPort(options.web_listen, &host, &port); !s.ok()) return s;
  const SecurityOptions& security = options.security;
  const bool loopback = IsLoopbackHost(host);
  if (!loopback && security.tls_cert_file.empty()) {
    if (!security.auth_token.empty()) {
      // As for the API: a token must not travel in clear off loopback.
      return absl::InvalidArgumentError(
          absl::StrCat("--web_listen=", options.web_listen,
                       ": a token without TLS is refused off loopback (set --tls_cert "
                       "and --tls_key)"));
    }
    Log(LogLevel::kWarning,
        absl::StrCat("web view on ", options.web_listen,
                     " without TLS and without a token: anyone who can reach the port "
                     "can read every session"));
  }
  web::WebViewOptions web;
  web.listen = options.web_listen;
  web.tls_cert_file = security.tls_cert_file;
  web.tls_key_file = security.tls_key_file;
  web.tls_client_ca_file = security.tls_client_ca_file;
  web.auth_token = security.auth_token;
  // In-process: no transport, so the web view checks TLS and the token itself.
  grpc::ChannelArguments arguments;
  arguments.SetMaxReceiveMessageSize(options.max_message_mb * 1024 * 1024);
  absl::StatusOr<std::unique_ptr<web::WebView>> view =
      web::WebView::Start(web, server_->InProcessChannel(arguments));
  if (!view.ok()) return view.status();
  web_view_ = *std::move(view);
  Log(LogLevel::kInfo,
      absl::StrCat("web view on port ", web_view_->port(), " (",
                   security.tls_cert_file.empty() ? "http" : "https", "://", host, ":",
                   web_view_->port(), "/",
                   security.auth_token.empty() ? "" : "#token=...", ")"));
  return absl::OkStatus();
}

int ExciteServer::web_port() const {
  return web_view_ != nullptr ? web_view_->port() : 0;
}

std::string ExciteServer::address() const {
  const bool v6 = host_.find(':') != std::string::npos;
  return v6 ? absl::StrCat("[", host_, "]:", port_) : absl::StrCat(host_, ":", port_);
}

void ExciteServer::Shutdown(std::chrono::milliseconds grace) {
  absl::MutexLock lock(&shutdown_mu_);
  if (shut_down_ || server_ == nullptr) return;
  shut_down_ = true;
  if (grpc::HealthCheckServiceInterface* health = server_->GetHealthCheckService()) {
    health->SetServingStatus(false);
  }
  // Refuse new RPCs, let those in flight finish within the grace period, then
  // shut down at once (cancelling whatever is still running).
  service_->StartDraining();
  if (!service_->WaitIdle(absl::FromChrono(grace))) {
    Log(LogLevel::kWarning, "grace period over: cancelling the RPCs still in flight");
  }
  server_->Shutdown(std::chrono::system_clock::now());
}

void ExciteServer::Wait() {
  if (server_ != nullptr) server_->Wait();
}

}  // namespace excite::service
