#ifndef EXCITE_SERVER_SERVICE_SESSION_ARCHIVE_H_
#define EXCITE_SERVER_SERVICE_SESSION_ARCHIVE_H_

#include <cstdint>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "excite/v1/exploration_service.pb.h"
#include "excite/v1/session_config.pb.h"
#include "server/store/store_records.h"

namespace excite::service {

// SessionArchive (ExportSession / ImportSession, the file of `excite export`):
// validation and translation to and from the store's records.

// The format version this server writes and the only one it reads.
inline constexpr int32_t kSessionArchiveFormatVersion = 1;

// Checks an archive as strictly as CreateSession plus AddData and returns its
// config validated with defaults filled. INVALID_ARGUMENT naming the field under
// `path`, e.g. "archive.samples[3].state": format_version must be
// kSessionArchiveFormatVersion; session_id empty or a valid id; config as
// ValidateSessionConfig; samples as ValidateTransitions (shapes, finite numbers,
// sequence in [0, kMaxSequence] and unique); hyperparameters empty or state_dim entries
// as ValidateHyperparameters; created_unix_ms in [0, kMaxUnixMs]; an unset config beside
// unreadable_config is refused with what to do. Caps are the caller's.
absl::StatusOr<v1::SessionConfig> ValidateSessionArchive(
    const v1::SessionArchive& archive, absl::string_view path = "archive");

// The archive of a stored session (samples in the order given, hyperparameters
// from the record's saved bytes). Never fails on what a store holds: a config
// that does not parse goes to unreadable_config (config unset), hyperparameters
// that do not parse are left out, and the creation time is clamped to the
// wire's range (WireUnixMs).
v1::SessionArchive ArchiveFromStore(const store::SessionRecord& record,
                                    const std::vector<store::SampleRecord>& samples);

// What ImportSession stores for a validated archive.
struct ArchiveRecords {
  // id left empty (the registry picks it); model_version 0.
  store::SessionRecord record;
  std::vector<store::SampleRecord> samples;
};
// `validated_config` is ValidateSessionArchive's result; a created_unix_ms of 0
// becomes `now_unix_ms`.
ArchiveRecords ArchiveToStore(const v1::SessionArchive& archive,
                              const v1::SessionConfig& validated_config,
                              int64_t now_unix_ms);

}  // namespace excite::service

#endif  // EXCITE_SERVER_SERVICE_SESSION_ARCHIVE_H_
