#ifndef EXCITE_SERVER_SERVICE_METRICS_H_
#define EXCITE_SERVER_SERVICE_METRICS_H_

#include <functional>
#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "grpcpp/support/server_interceptor.h"
#include "prometheus/counter.h"
#include "prometheus/exposer.h"
#include "prometheus/family.h"
#include "prometheus/histogram.h"
#include "prometheus/registry.h"
#include "server/session/metrics_sink.h"

namespace excite::service {

class CallbackGauges;
class ProcessCollector;
class BuildAndLockCollector;

// Process metrics, kept in a prometheus-cpp registry:
//   excite_rpc_total{grpc_service,grpc_method,code}            counter
//   excite_rpc_latency_seconds{grpc_service,grpc_method,code}  histogram
//   excite_samples_stored_total                   counter (AddData's and StreamData's
//                                                 `stored`)
//   excite_plan_seconds{strategy,solver_status}   histogram (PlanInputs' solver wall
//                                                 time, wall_time_ms; strategy: the
//                                                 one that planned, short name;
//                                                 solver_status: converged,
//                                                 time_limit, ...)
//   excite_fit_seconds                            histogram (GP refits)
//   excite_fits_stopped_total                     counter (refits ended early by a
//                                                 deadline or cancellation)
//   excite_store_write_seconds{op}                histogram (durable store writes)
//   gauges registered with AddGauge, read at every scrape (sessions, samples,
//   memory)
//   process_*, excite_build_info, excite_mumps_lock_*   (process_metrics.h)
// Thread-safe.
class Metrics final : public session::MetricsSink {
 public:
  Metrics();
  ~Metrics();
  Metrics(const Metrics&) = delete;
  Metrics& operator=(const Metrics&) = delete;

  // One finished RPC; `method` is the full path ("/pkg.Service/Method").
  void RecordRpc(absl::string_view method, absl::string_view code, double seconds);
  void AddSamplesStored(int64_t n);
  // One successful plan's solver wall time, the strategy that made it ("rec") and
  // how its solve ended ("converged", "time_limit").
  void RecordPlan(double seconds, absl::string_view strategy,
                  absl::string_view solver_status);
  // One refit of a session's GP (ML-II fit and factorisation); `stopped` if a
  // deadline or cancellation ended it early.
  void RecordFit(double seconds, bool stopped) override;
  // One durable store write; `op` names it ("insert_samples", "save_model").
  void RecordStoreWrite(absl::string_view op, double seconds) override;
  // A gauge read at every scrape; `read` must stay callable while this lives
  // and must not call back into this object.
  void AddGauge(const std::string& name, const std::string& help,
                std::function<double()> read);

  // Everything in the Prometheus text exposition format (version 0.0.4).
  std::string Render() const;
  // Serves these metrics on `exposer`'s /metrics; this must outlive it.
  void ExposeOn(prometheus::Exposer* exposer);

 private:
  std::shared_ptr<prometheus::Registry> registry_;
  std::shared_ptr<CallbackGauges> gauges_;
  std::shared_ptr<ProcessCollector> process_;
  std::shared_ptr<BuildAndLockCollector> build_and_lock_;
  prometheus::Family<prometheus::Counter>& rpc_total_;
  prometheus::Family<prometheus::Histogram>& rpc_latency_;
  prometheus::Family<prometheus::Histogram>& store_writes_;
  prometheus::Counter& samples_stored_;
  prometheus::Family<prometheus::Histogram>& plan_;
  prometheus::Histogram& fit_;
  prometheus::Counter& fits_stopped_;
};

// Records every RPC of the server (method, status code, latency, samples stored
// by AddData) into `metrics`, which must outlive the server. Calls rejected by
// the bearer-token check never reach interceptors and are not counted.
std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface>
MakeMetricsInterceptorFactory(Metrics* metrics);

// The HTTP endpoint: prometheus-cpp's exposer (civetweb, a pool of worker threads),
// GET /metrics, anything else 404. A slow or silent client holds one worker, not
// the others, and never delays destruction by more than civetweb's 2 s poll
// quantum.
class MetricsEndpoint {
 public:
  // `listen` is HOST:PORT (port 0: any free port); IPv4 hosts or "localhost".
  // `metrics` must outlive the endpoint. UNAVAILABLE if it cannot listen.
  static absl::StatusOr<std::unique_ptr<MetricsEndpoint>> Start(const std::string& listen,
                                                                Metrics* metrics);
  int port() const { return port_; }

 private:
  MetricsEndpoint() = default;

  std::unique_ptr<prometheus::Exposer> exposer_;
  int port_ = 0;
};

}  // namespace excite::service

#endif  // EXCITE_SERVER_SERVICE_METRICS_H_
