#ifndef EXCITE_SERVER_SERVICE_METRICS_H_
#define EXCITE_SERVER_SERVICE_METRICS_H_

#include <atomic>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "absl/synchronization/mutex.h"
#include "grpcpp/support/server_interceptor.h"

namespace excite::service {

// Process metrics in the Prometheus text exposition format (version 0.0.4):
//   excite_rpc_total{method,code}                 counter
//   excite_rpc_latency_seconds{method,code}       histogram
//   excite_samples_stored_total                   counter (AddData's `stored`)
//   excite_plan_seconds                           histogram (PlanInputs' solver
//                                                 wall time, wall_time_ms)
//   excite_fit_seconds                            histogram (GP refits)
//   excite_fits_stopped_total                     counter (refits ended early by a
//                                                 deadline or cancellation)
//   excite_store_write_seconds{op}                histogram (durable store writes)
//   gauges registered with AddGauge (sessions, samples).
// Thread-safe.
class Metrics {
 public:
  Metrics() = default;
  Metrics(const Metrics&) = delete;
  Metrics& operator=(const Metrics&) = delete;

  // One finished RPC; `method` is the full path ("/pkg.Service/Method").
  void RecordRpc(absl::string_view method, absl::string_view code, double seconds);
  void AddSamplesStored(int64_t n);
  // One successful plan's solver wall time.
  void RecordPlan(double seconds);
  // One refit of a session's GP (ML-II fit and factorisation); `stopped` if a
  // deadline or cancellation ended it early.
  void RecordFit(double seconds, bool stopped);
  // One durable store write; `op` names it ("insert_samples", "save_model").
  void RecordStoreWrite(absl::string_view op, double seconds);
  // A gauge read at every scrape; `read` must stay callable while this lives.
  void AddGauge(std::string name, std::string help, std::function<double()> read);

  std::string Render() const;

 private:
  struct Histogram {
    std::vector<int64_t> buckets;  // cumulative at render time, per bound here
    int64_t count = 0;
    double sum = 0;
  };
  struct Gauge {
    std::string name;
    std::string help;
    std::function<double()> read;
  };

  // Everything but the gauges.
  void RenderRecorded(std::string* out) const ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);

  mutable absl::Mutex mu_;
  // (method, code) -> latency histogram (its count is the RPC count).
  std::map<std::pair<std::string, std::string>, Histogram> rpcs_ ABSL_GUARDED_BY(mu_);
  std::vector<Gauge> gauges_ ABSL_GUARDED_BY(mu_);
  Histogram plan_ ABSL_GUARDED_BY(mu_);
  Histogram fit_ ABSL_GUARDED_BY(mu_);
  int64_t fits_stopped_ ABSL_GUARDED_BY(mu_) = 0;
  std::map<std::string, Histogram> store_writes_ ABSL_GUARDED_BY(mu_);
  std::atomic<int64_t> samples_stored_{0};
};

// Records every RPC of the server (method, status code, latency, samples stored
// by AddData) into `metrics`, which must outlive the server. Calls rejected by
// the bearer-token check never reach interceptors and are not counted.
std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface>
MakeMetricsInterceptorFactory(Metrics* metrics);

// A tiny single-threaded HTTP/1.0 responder: GET /metrics answers
// metrics->Render(), anything else 404. One connection at a time, 2 s I/O
// timeouts. Stops (and joins its thread) on destruction.
class MetricsHttpServer {
 public:
  // `listen` is HOST:PORT (port 0: any free port); IPv4 hosts or "localhost".
  static absl::StatusOr<std::unique_ptr<MetricsHttpServer>> Start(
      const std::string& listen, const Metrics* metrics);
  ~MetricsHttpServer();
  MetricsHttpServer(const MetricsHttpServer&) = delete;
  MetricsHttpServer& operator=(const MetricsHttpServer&) = delete;

  int port() const { return port_; }

 private:
  MetricsHttpServer() = default;
  void Serve();

  const Metrics* metrics_ = nullptr;
  int fd_ = -1;
  int port_ = 0;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace excite::service

#endif  // EXCITE_SERVER_SERVICE_METRICS_H_
