// libFuzzer target for the untrusted-input paths of excite-server: a
// SessionConfig as textproto (config files, excite-sim, the CLI) and as binary
// protobuf (CreateSession), its validation, the validation of AddData,
// Predict and PlanInputs requests against a validated config, and of a
// SessionArchive (ImportSession, `excite import` files). Must never crash
// (ASan); validation must be idempotent (a validated config validates again,
// unchanged), else the target aborts.

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "absl/status/statusor.h"
#include "excite/v1/exploration_service.pb.h"
#include "excite/v1/session_config.pb.h"
#include "server/service/config_text.h"
#include "server/service/config_validation.h"
#include "server/service/request_validation.h"
#include "server/service/session_archive.h"

namespace excite::service {
namespace {

void CheckRequests(const v1::SessionConfig& config, const std::string& bytes) {
  v1::AddDataRequest add;
  if (add.ParseFromString(bytes)) (void)ValidateTransitions(config, add.transitions());
  v1::PredictRequest predict;
  if (predict.ParseFromString(bytes)) {
    (void)ValidatePredictInputs(config, predict.inputs(), 1000);
  }
  v1::PlanInputsRequest plan;
  if (plan.ParseFromString(bytes)) (void)ValidatePlanState(config, plan.state());
}

void Exercise(const v1::SessionConfig& config, const std::string& bytes) {
  absl::StatusOr<v1::SessionConfig> validated = ValidatedSessionConfig(config);
  if (!validated.ok()) return;
  absl::StatusOr<v1::SessionConfig> again = ValidatedSessionConfig(*validated);
  if (!again.ok() || again->SerializeAsString() != validated->SerializeAsString()) {
    std::abort();  // validation is not idempotent
  }
  CheckRequests(*validated, bytes);
}

}  // namespace
}  // namespace excite::service

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  absl::StatusOr<excite::v1::SessionConfig> text =
      excite::service::ParseSessionConfigText(bytes);
  if (text.ok()) excite::service::Exercise(*text, bytes);
  excite::v1::SessionConfig binary;
  if (binary.ParseFromString(bytes)) excite::service::Exercise(binary, bytes);
  excite::v1::SessionArchive archive;
  if (archive.ParseFromString(bytes)) {
    (void)excite::service::ValidateSessionArchive(archive);
  }
  return 0;
}
