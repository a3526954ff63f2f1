#include "server/service/metrics.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <cstring>

#include "absl/status/status.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "excite/v1/exploration_service.pb.h"
#include "server/service/excite_server.h"

namespace excite::service {
namespace {

// Latency bucket upper bounds in seconds (planning can take tens of seconds).
constexpr std::array<double, 12> kBounds = {0.001, 0.005, 0.01, 0.025, 0.05, 0.1,
                                            0.25,  0.5,   1.0,  2.5,   10.0, 30.0};

constexpr absl::string_view kAddDataPath = "/excite.v1.ExplorationService/AddData";
constexpr absl::string_view kPlanPath = "/excite.v1.ExplorationService/PlanInputs";

void Observe(std::vector<int64_t>* buckets, int64_t* count, double* sum, double seconds) {
  if (buckets->empty()) buckets->assign(kBounds.size(), 0);
  for (size_t i = 0; i < kBounds.size(); ++i) {
    if (seconds <= kBounds[i]) {
      ++(*buckets)[i];
      break;
    }
  }
  ++*count;
  *sum += seconds;
}

// Prometheus lines of one histogram; `labels` is "" or "k=\"v\",...".
void AppendHistogram(std::string* out, absl::string_view name, absl::string_view labels,
                     const std::vector<int64_t>& buckets, int64_t count, double sum) {
  const std::string sep = labels.empty() ? "" : ",";
  int64_t cumulative = 0;
  for (size_t i = 0; i < kBounds.size(); ++i) {
    cumulative += buckets.empty() ? 0 : buckets[i];
    absl::StrAppend(out, name, "_bucket{", labels, sep, "le=\"", kBounds[i], "\"} ",
                    cumulative, "\n");
  }
  const std::string braces = labels.empty() ? "" : absl::StrCat("{", labels, "}");
  absl::StrAppend(out, name, "_bucket{", labels, sep, "le=\"+Inf\"} ", count, "\n", name,
                  "_sum", braces, " ", sum, "\n", name, "_count", braces, " ", count,
                  "\n");
}

class MetricsInterceptor final : public grpc::experimental::Interceptor {
 public:
  MetricsInterceptor(Metrics* metrics, const char* method)
      : metrics_(metrics),
        method_(method != nullptr ? method : "unknown"),
        start_(std::chrono::steady_clock::now()) {}

  void Intercept(grpc::experimental::InterceptorBatchMethods* methods) override {
    using grpc::experimental::InterceptionHookPoints;
    if (methods->QueryInterceptionHookPoint(InterceptionHookPoints::PRE_SEND_MESSAGE) &&
        method_ == kAddDataPath) {
      if (const auto* response =
              static_cast<const v1::AddDataResponse*>(methods->GetSendMessage())) {
        metrics_->AddSamplesStored(response->stored());
      }
    }
    if (methods->QueryInterceptionHookPoint(InterceptionHookPoints::PRE_SEND_MESSAGE) &&
        method_ == kPlanPath) {
      if (const auto* response =
              static_cast<const v1::PlanInputsResponse*>(methods->GetSendMessage())) {
        metrics_->RecordPlan(response->wall_time_ms() / 1000.0);
      }
    }
    if (methods->QueryInterceptionHookPoint(InterceptionHookPoints::PRE_SEND_STATUS)) {
      const double seconds =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start_)
              .count();
      metrics_->RecordRpc(method_,
                          absl::StatusCodeToString(static_cast<absl::StatusCode>(
                              methods->GetSendStatus().error_code())),
                          seconds);
    }
    methods->Proceed();
  }

 private:
  Metrics* const metrics_;
  const std::string method_;
  const std::chrono::steady_clock::time_point start_;
};

class MetricsInterceptorFactory final
    : public grpc::experimental::ServerInterceptorFactoryInterface {
 public:
  explicit MetricsInterceptorFactory(Metrics* metrics) : metrics_(metrics) {}
  grpc::experimental::Interceptor* CreateServerInterceptor(
      grpc::experimental::ServerRpcInfo* info) override {
    return new MetricsInterceptor(metrics_, info->method());
  }

 private:
  Metrics* const metrics_;
};

bool SendAll(int fd, const std::string& data) {
  size_t sent = 0;
  while (sent < data.size()) {
    const ssize_t n = send(fd, data.data() + sent, data.size() - sent, MSG_NOSIGNAL);
    if (n <= 0) return false;
    sent += static_cast<size_t>(n);
  }
  return true;
}

}  // namespace

void Metrics::RecordRpc(absl::string_view method, absl::string_view code,
                        double seconds) {
  absl::MutexLock lock(&mu_);
  Histogram& h = rpcs_[{std::string(method), std::string(code)}];
  Observe(&h.buckets, &h.count, &h.sum, seconds);
}

void Metrics::RecordPlan(double seconds) {
  absl::MutexLock lock(&mu_);
  Observe(&plan_.buckets, &plan_.count, &plan_.sum, seconds);
}

void Metrics::RecordFit(double seconds, bool stopped) {
  absl::MutexLock lock(&mu_);
  Observe(&fit_.buckets, &fit_.count, &fit_.sum, seconds);
  if (stopped) ++fits_stopped_;
}

void Metrics::RecordStoreWrite(absl::string_view op, double seconds) {
  absl::MutexLock lock(&mu_);
  Histogram& h = store_writes_[std::string(op)];
  Observe(&h.buckets, &h.count, &h.sum, seconds);
}

void Metrics::AddSamplesStored(int64_t n) { samples_stored_ += n; }

void Metrics::AddGauge(std::string name, std::string help, std::function<double()> read) {
  absl::MutexLock lock(&mu_);
  gauges_.push_back({std::move(name), std::move(help), std::move(read)});
}

std::string Metrics::Render() const {
  std::string out;
  std::vector<Gauge> gauges;
  {
    absl::MutexLock lock(&mu_);
    RenderRecorded(&out);
    gauges = gauges_;
  }
  // Gauges read session state: outside mu_, which sessions take while they hold
  // their own locks (RecordFit, RecordStoreWrite).
  for (const Gauge& g : gauges) {
    absl::StrAppend(&out, "# HELP ", g.name, " ", g.help, "\n# TYPE ", g.name, " gauge\n",
                    g.name, " ", g.read(), "\n");
  }
  return out;
}

void Metrics::RenderRecorded(std::string* out_ptr) const {
  std::string& out = *out_ptr;
  absl::StrAppend(&out, "# HELP excite_rpc_total RPCs finished, by method and code.\n",
                  "# TYPE excite_rpc_total counter\n");
  for (const auto& [key, h] : rpcs_) {
    absl::StrAppend(&out, "excite_rpc_total{method=\"", key.first, "\",code=\"",
                    key.second, "\"} ", h.count, "\n");
  }
  absl::StrAppend(&out,
                  "# HELP excite_rpc_latency_seconds RPC latency as the server sees "
                  "it, by method and code.\n",
                  "# TYPE excite_rpc_latency_seconds histogram\n");
  for (const auto& [key, h] : rpcs_) {
    AppendHistogram(&out, "excite_rpc_latency_seconds",
                    absl::StrCat("method=\"", key.first, "\",code=\"", key.second, "\""),
                    h.buckets, h.count, h.sum);
  }
  absl::StrAppend(&out,
                  "# HELP excite_plan_seconds Solver wall time of successful "
                  "PlanInputs calls.\n# TYPE excite_plan_seconds histogram\n");
  AppendHistogram(&out, "excite_plan_seconds", "", plan_.buckets, plan_.count, plan_.sum);
  absl::StrAppend(&out,
                  "# HELP excite_fit_seconds Wall time of GP refits (hyperparameter "
                  "fit and factorisation).\n# TYPE excite_fit_seconds histogram\n");
  AppendHistogram(&out, "excite_fit_seconds", "", fit_.buckets, fit_.count, fit_.sum);
  absl::StrAppend(&out,
                  "# HELP excite_fits_stopped_total Refits ended early by a deadline "
                  "or cancellation.\n# TYPE excite_fits_stopped_total counter\n"
                  "excite_fits_stopped_total ",
                  fits_stopped_, "\n");
  absl::StrAppend(&out,
                  "# HELP excite_store_write_seconds Durable store writes (fsync "
                  "included), by operation.\n"
                  "# TYPE excite_store_write_seconds histogram\n");
  for (const auto& [op, h] : store_writes_) {
    AppendHistogram(&out, "excite_store_write_seconds", absl::StrCat("op=\"", op, "\""),
                    h.buckets, h.count, h.sum);
  }
  absl::StrAppend(&out,
                  "# HELP excite_samples_stored_total Transitions stored by AddData.\n"
                  "# TYPE excite_samples_stored_total counter\n"
                  "excite_samples_stored_total ",
                  samples_stored_.load(), "\n");
}

std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface>
MakeMetricsInterceptorFactory(Metrics* metrics) {
  return std::make_unique<MetricsInterceptorFactory>(metrics);
}

absl::StatusOr<std::unique_ptr<MetricsHttpServer>> MetricsHttpServer::Start(
    const std::string& listen, const Metrics* metrics) {
  std::string host;
  int port = 0;
  if (absl::Status s = SplitHostPort(listen, &host, &port); !s.ok()) return s;
  if (host == "localhost") host = "127.0.0.1";
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<uint16_t>(port));
  if (inet_pton(AF_INET, host.c_str(), &addr.sin_addr) != 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("metrics address \"", listen, "\": host must be IPv4"));
  }
  std::unique_ptr<MetricsHttpServer> server(new MetricsHttpServer());
  server->metrics_ = metrics;
  server->fd_ = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (server->fd_ < 0) return absl::UnavailableError("metrics: socket() failed");
  const int one = 1;
  setsockopt(server->fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one));
  if (bind(server->fd_, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0 ||
      ::listen(server->fd_, 16) != 0) {
    return absl::UnavailableError(
        absl::StrCat("metrics: cannot listen on ", listen, ": ", std::strerror(errno)));
  }
  socklen_t len = sizeof(addr);
  getsockname(server->fd_, reinterpret_cast<sockaddr*>(&addr), &len);
  server->port_ = ntohs(addr.sin_port);
  server->thread_ = std::thread([s = server.get()]() { s->Serve(); });
  return server;
}

MetricsHttpServer::~MetricsHttpServer() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  if (fd_ >= 0) close(fd_);
}

void MetricsHttpServer::Serve() {
  while (!stop_) {
    pollfd p{fd_, POLLIN, 0};
    if (poll(&p, 1, 200) <= 0) continue;
    const int client = accept4(fd_, nullptr, nullptr, SOCK_CLOEXEC);
    if (client < 0) continue;
    timeval timeout{2, 0};
    setsockopt(client, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof(timeout));
    setsockopt(client, SOL_SOCKET, SO_SNDTIMEO, &timeout, sizeof(timeout));
    std::string request;
    char buffer[1024];
    while (request.size() < 8192 && request.find("\r\n\r\n") == std::string::npos) {
      const ssize_t n = recv(client, buffer, sizeof(buffer), 0);
      if (n <= 0) break;
      request.append(buffer, static_cast<size_t>(n));
    }
    std::string body;
    std::string status = "404 Not Found";
    if (absl::StartsWith(request, "GET /metrics ") ||
        absl::StartsWith(request, "GET /metrics?")) {
      status = "200 OK";
      body = metrics_->Render();
    }
    SendAll(client,
            absl::StrCat("HTTP/1.0 ", status,
                         "\r\nContent-Type: text/plain; version=0.0.4; charset=utf-8\r\n"
                         "Content-Length: ",
                         body.size(), "\r\nConnection: close\r\n\r\n", body));
    close(client);
  }
}

}  // namespace excite::service
