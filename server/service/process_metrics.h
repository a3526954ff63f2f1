#ifndef EXCITE_SERVER_SERVICE_PROCESS_METRICS_H_
#define EXCITE_SERVER_SERVICE_PROCESS_METRICS_H_

#include <vector>

#include "prometheus/collectable.h"
#include "prometheus/metric_family.h"

namespace excite::service {

// The standard process_* metrics of Prometheus clients, read from /proc/self at
// every scrape (prometheus-cpp has no process collector):
//   process_cpu_seconds_total, process_resident_memory_bytes,
//   process_virtual_memory_bytes, process_start_time_seconds (Unix time),
//   process_open_fds, process_max_fds, process_threads.
// A value /proc does not give (another kernel, a locked-down sandbox) is left out.
class ProcessCollector final : public prometheus::Collectable {
 public:
  std::vector<prometheus::MetricFamily> Collect() const override;
};

// excite_build_info{version,commit} 1, the time MUMPS calls spent waiting for and
// holding their copies' locks (excite_mumps_lock_*) and the copies loaded
// (excite_mumps_copies; see plan::MumpsLockTotals).
class BuildAndLockCollector final : public prometheus::Collectable {
 public:
  std::vector<prometheus::MetricFamily> Collect() const override;
};

}  // namespace excite::service

#endif  // EXCITE_SERVER_SERVICE_PROCESS_METRICS_H_
