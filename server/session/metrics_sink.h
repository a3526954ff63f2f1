#ifndef EXCITE_SERVER_SESSION_METRICS_SINK_H_
#define EXCITE_SERVER_SESSION_METRICS_SINK_H_

#include "absl/strings/string_view.h"

namespace excite::session {

// Where sessions report their timings (the server's metrics endpoint implements
// it). Thread-safe.
class MetricsSink {
 public:
  virtual ~MetricsSink() = default;
  // One store write of `what` ("insert_samples", "save_model").
  virtual void RecordStoreWrite(absl::string_view what, double seconds) = 0;
  // One refit; `stopped`: ended early by a deadline or a cancellation.
  virtual void RecordFit(double seconds, bool stopped) = 0;
};

}  // namespace excite::session

#endif  // EXCITE_SERVER_SESSION_METRICS_SINK_H_
