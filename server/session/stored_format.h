#ifndef EXCITE_SERVER_SESSION_STORED_FORMAT_H_
#define EXCITE_SERVER_SESSION_STORED_FORMAT_H_

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "server/gp/hyperparameters.h"
#include "server/session/session_spec.h"

namespace excite::session {

// Hyperparameters as a session saves them: one per output, in data units, and
// how many samples they were fitted on (0 if unknown).
struct SavedFit {
  std::vector<gp::Hyperparameters> hyperparameters;
  int64_t fitted_samples = 0;
};

// The formats of the opaque bytes a session keeps in the store (its config and
// its saved fit): the API layer's (protobuf), so the domain stays free of them.
// Implementations are immutable and thread-safe.
class StoredFormat {
 public:
  virtual ~StoredFormat() = default;
  // The spec of stored config bytes (SessionRecord::config). DATA_LOSS if they
  // do not parse.
  virtual absl::StatusOr<SessionSpec> DecodeConfig(const std::string& bytes) const = 0;
  // SessionRecord::hyperparameters.
  virtual std::string EncodeFit(const SavedFit& fit) const = 0;
  // nullopt if `bytes` are empty, do not parse, or do not hold `state_dim`
  // outputs of `kernel_inputs` lengthscales each (SessionSpec::kernel_inputs();
  // a cache: the session fits anew).
  virtual std::optional<SavedFit> DecodeFit(const std::string& bytes, int state_dim,
                                            int kernel_inputs) const = 0;
};

}  // namespace excite::session

#endif  // EXCITE_SERVER_SESSION_STORED_FORMAT_H_
