#include "server/service/metrics.h"

#include <arpa/inet.h>

#include <chrono>
#include <exception>
#include <initializer_list>
#include <utility>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/status/status.h"
#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/strip.h"
#include "absl/synchronization/mutex.h"
#include "excite/v1/exploration_service.pb.h"
#include "prometheus/collectable.h"
#include "prometheus/metric_family.h"
#include "prometheus/text_serializer.h"
#include "server/service/excite_server.h"
#include "server/service/process_metrics.h"
#include "server/service/strategy_names.h"

namespace excite::service {
namespace {

// Latency bucket upper bounds in seconds (planning can take tens of seconds).
const prometheus::Histogram::BucketBoundaries& Bounds() {
  static const auto* const bounds = new prometheus::Histogram::BucketBoundaries{
      0.001, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1.0, 2.5, 10.0, 30.0};
  return *bounds;
}

constexpr absl::string_view kAddDataPath = "/excite.v1.ExplorationService/AddData";
constexpr absl::string_view kStreamDataPath = "/excite.v1.ExplorationService/StreamData";
constexpr absl::string_view kPlanPath = "/excite.v1.ExplorationService/PlanInputs";

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
        method_ == kStreamDataPath) {
      if (const auto* ack =
              static_cast<const v1::AddDataAck*>(methods->GetSendMessage())) {
        metrics_->AddSamplesStored(ack->stored());
      }
    }
    if (methods->QueryInterceptionHookPoint(InterceptionHookPoints::PRE_SEND_MESSAGE) &&
        method_ == kPlanPath) {
      if (const auto* response =
              static_cast<const v1::PlanInputsResponse*>(methods->GetSendMessage())) {
        const std::string name = v1::SolverStatus_Name(response->solver_status());
        absl::string_view status = name;
        absl::ConsumePrefix(&status, "SOLVER_STATUS_");
        metrics_->RecordPlan(response->wall_time_ms() / 1000.0,
                             StrategyShortName(response->planned_by()),
                             absl::AsciiStrToLower(status));
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

}  // namespace

// Gauges whose value is read when scraped (a prometheus::Gauge holds a value set
// beforehand; these values live elsewhere: the registry, the memory estimate).
class CallbackGauges final : public prometheus::Collectable {
 public:
  void Add(const std::string& name, const std::string& help,
           std::function<double()> read) {
    absl::MutexLock lock(&mu_);
    gauges_.push_back({name, help, std::move(read)});
  }

  std::vector<prometheus::MetricFamily> Collect() const override {
    std::vector<Gauge> gauges;
    {
      absl::MutexLock lock(&mu_);
      gauges = gauges_;
    }
    // Read outside mu_: gauges read session state under the sessions' locks.
    std::vector<prometheus::MetricFamily> families;
    for (const Gauge& g : gauges) {
      prometheus::MetricFamily family;
      family.name = g.name;
      family.help = g.help;
      family.type = prometheus::MetricType::Gauge;
      family.metric.emplace_back().gauge.value = g.read();
      families.push_back(std::move(family));
    }
    return families;
  }

 private:
  struct Gauge {
    std::string name;
    std::string help;
    std::function<double()> read;
  };
  mutable absl::Mutex mu_;
  std::vector<Gauge> gauges_ ABSL_GUARDED_BY(mu_);
};

Metrics::Metrics()
    : registry_(std::make_shared<prometheus::Registry>()),
      gauges_(std::make_shared<CallbackGauges>()),
      process_(std::make_shared<ProcessCollector>()),
      build_and_lock_(std::make_shared<BuildAndLockCollector>()),
      rpc_total_(prometheus::BuildCounter()
                     .Name("excite_rpc_total")
                     .Help("RPCs finished, by gRPC service, method and code.")
                     .Register(*registry_)),
      rpc_latency_(
          prometheus::BuildHistogram()
              .Name("excite_rpc_latency_seconds")
              .Help(
                  "RPC latency as the server sees it, by gRPC service, method and code.")
              .Register(*registry_)),
      store_writes_(prometheus::BuildHistogram()
                        .Name("excite_store_write_seconds")
                        .Help("Durable store writes (fsync included), by operation.")
                        .Register(*registry_)),
      samples_stored_(prometheus::BuildCounter()
                          .Name("excite_samples_stored_total")
                          .Help("Transitions stored by AddData.")
                          .Register(*registry_)
                          .Add({})),
      plan_(prometheus::BuildHistogram()
                .Name("excite_plan_seconds")
                .Help("Solver wall time of successful PlanInputs calls, by the strategy "
                      "that planned (auto: its member) and how the solve ended.")
                .Register(*registry_)),
      fit_(prometheus::BuildHistogram()
               .Name("excite_fit_seconds")
               .Help("Wall time of GP refits (hyperparameter fit and factorisation).")
               .Register(*registry_)
               .Add({}, Bounds())),
      fits_stopped_(prometheus::BuildCounter()
                        .Name("excite_fits_stopped_total")
                        .Help("Refits ended early by a deadline or cancellation.")
                        .Register(*registry_)
                        .Add({})) {}

Metrics::~Metrics() = default;

void Metrics::RecordRpc(absl::string_view method, absl::string_view code,
                        double seconds) {
  // "/excite.v1.ExplorationService/PlanInputs": service and method apart, as
  // gRPC's own metrics name them.
  absl::string_view path = method;
  absl::ConsumePrefix(&path, "/");
  const size_t slash = path.rfind('/');
  const std::string service =
      slash == absl::string_view::npos ? "unknown" : std::string(path.substr(0, slash));
  const std::string name =
      std::string(slash == absl::string_view::npos ? path : path.substr(slash + 1));
  const prometheus::Labels labels = {
      {"grpc_service", service}, {"grpc_method", name}, {"code", std::string(code)}};
  rpc_total_.Add(labels).Increment();
  rpc_latency_.Add(labels, Bounds()).Observe(seconds);
}

void Metrics::AddSamplesStored(int64_t n) {
  samples_stored_.Increment(static_cast<double>(n));
}

void Metrics::RecordPlan(double seconds, absl::string_view strategy,
                         absl::string_view solver_status) {
  plan_
      .Add({{"strategy", std::string(strategy)},
            {"solver_status", std::string(solver_status)}},
           Bounds())
      .Observe(seconds);
}

void Metrics::RecordFit(double seconds, bool stopped) {
  fit_.Observe(seconds);
  if (stopped) fits_stopped_.Increment();
}

void Metrics::RecordStoreWrite(absl::string_view op, double seconds) {
  store_writes_.Add({{"op", std::string(op)}}, Bounds()).Observe(seconds);
}

void Metrics::AddGauge(const std::string& name, const std::string& help,
                       std::function<double()> read) {
  gauges_->Add(name, help, std::move(read));
}

std::string Metrics::Render() const {
  std::vector<prometheus::MetricFamily> families = registry_->Collect();
  for (const prometheus::Collectable* more :
       std::initializer_list<const prometheus::Collectable*>{
           gauges_.get(), process_.get(), build_and_lock_.get()}) {
    for (prometheus::MetricFamily& family : more->Collect()) {
      families.push_back(std::move(family));
    }
  }
  return prometheus::TextSerializer().Serialize(families);
}

void Metrics::ExposeOn(prometheus::Exposer* exposer) {
  exposer->RegisterCollectable(registry_);
  exposer->RegisterCollectable(gauges_);
  exposer->RegisterCollectable(process_);
  exposer->RegisterCollectable(build_and_lock_);
}

std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface>
MakeMetricsInterceptorFactory(Metrics* metrics) {
  return std::make_unique<MetricsInterceptorFactory>(metrics);
}

absl::StatusOr<std::unique_ptr<MetricsEndpoint>> MetricsEndpoint::Start(
    const std::string& listen, Metrics* metrics) {
  std::string host;
  int port = 0;
  if (absl::Status s = SplitHostPort(listen, &host, &port); !s.ok()) return s;
  if (host == "localhost") host = "127.0.0.1";
  in_addr parsed{};
  if (inet_pton(AF_INET, host.c_str(), &parsed) != 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("metrics address \"", listen, "\": host must be IPv4"));
  }
  std::unique_ptr<MetricsEndpoint> endpoint(new MetricsEndpoint());
  try {
    // Four workers: a few stuck scrapers cannot starve Prometheus. A request must
    // arrive whole within 5 s.
    endpoint->exposer_ = std::make_unique<prometheus::Exposer>(
        std::vector<std::string>{"listening_ports", absl::StrCat(host, ":", port),
                                 "num_threads", "4", "request_timeout_ms", "5000"});
  } catch (const std::exception& e) {
    return absl::UnavailableError(
        absl::StrCat("metrics: cannot listen on ", listen, ": ", e.what()));
  }
  metrics->ExposeOn(endpoint->exposer_.get());
  const std::vector<int> ports = endpoint->exposer_->GetListeningPorts();
  if (ports.empty() || ports.front() <= 0) {
    return absl::UnavailableError(absl::StrCat("metrics: no port bound for ", listen));
  }
  endpoint->port_ = ports.front();
  return endpoint;
}

}  // namespace excite::service
