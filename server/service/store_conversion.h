#ifndef EXCITE_SERVER_SERVICE_STORE_CONVERSION_H_
#define EXCITE_SERVER_SERVICE_STORE_CONVERSION_H_

#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "excite/v1/exploration_service.pb.h"
#include "excite/v1/session_config.pb.h"
#include "google/protobuf/repeated_field.h"
#include "server/gp/hyperparameters.h"
#include "server/session/stored_format.h"
#include "server/store/store_records.h"

namespace excite::service {

// Wire messages <-> the store's records (the only place where they meet).

// A Transition as the store keeps it, and back (every field is kept).
store::SampleRecord ToSampleRecord(const v1::Transition& transition);
v1::Transition ToTransition(const store::SampleRecord& sample);

// A stored creation time (ms since the Unix epoch) as the wire can carry it:
// 0 (unknown) for a negative one, kMaxUnixMs for one past it. Imports store
// none such (ValidateSessionArchive), but rows written by an older server or by
// hand may hold any int64, and one row must not make ListSessions fail.
int64_t WireUnixMs(int64_t stored_unix_ms);

// The store's opaque hyperparameter bytes (SessionRecord::hyperparameters) are a
// serialized Session holding only `outputs` and, as `sample_count`, the number of
// samples the hyperparameters were fitted on (0 if unknown: saved before it was
// kept, or imported without it).
struct ArchivedFit {
  std::vector<v1::Hyperparameters> hyperparameters;  // one per output
  int64_t fitted_samples = 0;
};
std::string EncodeSavedHyperparameters(
    const google::protobuf::RepeatedPtrField<v1::Hyperparameters>& hyperparameters,
    int64_t fitted_samples);
// nullopt if `bytes` do not parse. Empty bytes (never fitted) give no
// hyperparameters.
std::optional<ArchivedFit> DecodeSavedHyperparameters(const std::string& bytes);

// The formats of a session's stored bytes for the session domain: the config is
// a serialized SessionConfig (decoded as stored, not validated again: what an
// older server stored is restored as it was), the fit as above.
class ProtoStoredFormat final : public session::StoredFormat {
 public:
  absl::StatusOr<session::SessionSpec> DecodeConfig(
      const std::string& bytes) const override;
  std::string EncodeFit(const session::SavedFit& fit) const override;
  std::optional<session::SavedFit> DecodeFit(const std::string& bytes, int state_dim,
                                             int kernel_inputs) const override;
};

}  // namespace excite::service

#endif  // EXCITE_SERVER_SERVICE_STORE_CONVERSION_H_
