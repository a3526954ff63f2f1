#include "server/service/session_archive.h"

#include <optional>
#include <string>
#include <utility>

#include "absl/strings/str_cat.h"
#include "server/service/config_validation.h"
#include "server/service/field_violation.h"
#include "server/service/request_validation.h"
#include "server/service/resource_name.h"
#include "server/service/session_labels.h"
#include "server/service/store_conversion.h"
#include "server/service/value_ranges.h"

namespace excite::service {

absl::StatusOr<v1::SessionConfig> ValidateSessionArchive(
    const v1::SessionArchive& archive, absl::string_view path) {
  if (archive.format_version() != kSessionArchiveFormatVersion) {
    return FieldViolationError(
        absl::StrCat(path, ".format_version"),
        absl::StrCat("must be ", kSessionArchiveFormatVersion,
                     " (the archive format this server reads), got ",
                     archive.format_version(),
                     archive.format_version() > kSessionArchiveFormatVersion
                         ? ": written by a newer excite-server"
                         : ": not a SessionArchive written by excite export"));
  }
  if (absl::Status s =
          CheckOptionalSessionId(archive.session_id(), absl::StrCat(path, ".session_id"));
      !s.ok()) {
    return s;
  }
  if (!archive.has_config() && !archive.unreadable_config().empty()) {
    return FieldViolationError(
        absl::StrCat(path, ".config"),
        "unset: the archive was exported from a session whose stored config does not "
        "parse (its bytes are in unreadable_config); set config to the session's "
        "configuration and import again");
  }
  absl::StatusOr<v1::SessionConfig> config =
      ValidatedSessionConfig(archive.config(), absl::StrCat(path, ".config"));
  if (!config.ok()) return config.status();
  if (absl::Status s =
          ValidateTransitions({config->state_dim(), config->input_dim()},
                              archive.samples(), absl::StrCat(path, ".samples"));
      !s.ok()) {
    return s;
  }
  const std::string hpath = absl::StrCat(path, ".hyperparameters");
  if (!archive.hyperparameters().empty()) {
    if (archive.hyperparameters_size() != config->state_dim()) {
      return FieldViolationError(
          hpath, absl::StrCat("must be empty or have state_dim (", config->state_dim(),
                              ") entries, got ", archive.hyperparameters_size()));
    }
    for (int i = 0; i < archive.hyperparameters_size(); ++i) {
      if (absl::Status s =
              ValidateHyperparameters(absl::StrCat(hpath, "[", i, "]"),
                                      archive.hyperparameters(i), KernelInputs(*config));
          !s.ok()) {
        return s;
      }
    }
  }
  if (archive.fitted_sample_count() < 0 ||
      archive.fitted_sample_count() > archive.samples_size() ||
      (archive.hyperparameters().empty() && archive.fitted_sample_count() != 0)) {
    return FieldViolationError(
        absl::StrCat(path, ".fitted_sample_count"),
        absl::StrCat("must be in [0, ", archive.samples_size(),
                     "] (the number of samples), and 0 without hyperparameters; got ",
                     archive.fitted_sample_count()));
  }
  if (archive.created_unix_ms() < 0 || archive.created_unix_ms() > kMaxUnixMs) {
    return FieldViolationError(
        absl::StrCat(path, ".created_unix_ms"),
        absl::StrCat("must be in [0, ", kMaxUnixMs,
                     "] (0: unknown; the largest is the end of the year 9999), got ",
                     archive.created_unix_ms()));
  }
  if (absl::Status s = ValidateDisplayNameAndLabels(
          archive.display_name(), archive.labels(), absl::StrCat(path, "."));
      !s.ok()) {
    return s;
  }
  return config;
}

v1::SessionArchive ArchiveFromStore(const store::SessionRecord& record,
                                    const std::vector<store::SampleRecord>& samples) {
  v1::SessionArchive archive;
  archive.set_format_version(kSessionArchiveFormatVersion);
  archive.set_session_id(record.id);
  if (!archive.mutable_config()->ParseFromString(record.config)) {
    archive.clear_config();
    archive.set_unreadable_config(record.config);
  }
  // The fit is derived from the samples: one that does not parse is left out
  // (the importing server fits anew), not a reason to keep the samples in.
  if (std::optional<ArchivedFit> saved =
          DecodeSavedHyperparameters(record.hyperparameters);
      saved.has_value()) {
    for (v1::Hyperparameters& h : saved->hyperparameters) {
      *archive.add_hyperparameters() = std::move(h);
    }
    archive.set_fitted_sample_count(saved->fitted_samples);
  }
  archive.mutable_samples()->Reserve(static_cast<int>(samples.size()));
  for (const store::SampleRecord& sample : samples) {
    *archive.add_samples() = ToTransition(sample);
  }
  archive.set_created_unix_ms(WireUnixMs(record.created_unix_ms));
  archive.set_display_name(record.display_name);
  archive.mutable_labels()->insert(record.labels.begin(), record.labels.end());
  return archive;
}

ArchiveRecords ArchiveToStore(const v1::SessionArchive& archive,
                              const v1::SessionConfig& validated_config,
                              int64_t now_unix_ms) {
  ArchiveRecords out;
  out.record.config = validated_config.SerializeAsString();
  out.record.created_unix_ms =
      archive.created_unix_ms() > 0 ? archive.created_unix_ms() : now_unix_ms;
  out.record.hyperparameters = EncodeSavedHyperparameters(archive.hyperparameters(),
                                                          archive.fitted_sample_count());
  out.record.display_name = archive.display_name();
  out.record.labels = Labels(archive.labels().begin(), archive.labels().end());
  out.samples.reserve(static_cast<size_t>(archive.samples_size()));
  for (const v1::Transition& t : archive.samples()) {
    out.samples.push_back(ToSampleRecord(t));
  }
  return out;
}

}  // namespace excite::service
