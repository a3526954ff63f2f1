// libFuzzer target for the untrusted-input paths of excite-server: a
// SessionConfig as textproto (config files, excite-sim, the CLI) and as binary
// protobuf (CreateSession), its validation, the validation of AddData,
// Predict and PlanInputs requests against a validated config, and of a
// SessionArchive (ImportSession, `excite import` files: what it stores must read
// back and export to an archive that imports again) and ListSessions' label
// filter. Must never crash
// (ASan); validation must be idempotent (a validated config validates again,
// unchanged), else the target aborts. Transitions that pass validation are
// given to the session's GP model as the server would (delta or next target,
// prior mean, standardisation, a short fit): the model must take them, fit and
// predict finite numbers, else the target aborts (a poisoned session).

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "Eigen/Dense"
#include "absl/status/statusor.h"
#include "excite/v1/exploration_service.pb.h"
#include "excite/v1/session_config.pb.h"
#include "google/protobuf/util/time_util.h"
#include "server/gp/dynamics_model.h"
#include "server/service/config_text.h"
#include "server/service/config_validation.h"
#include "server/service/request_validation.h"
#include "server/service/session_archive.h"
#include "server/service/session_labels.h"
#include "server/service/session_options.h"
#include "server/service/store_conversion.h"

namespace excite::service {
namespace {

// Validated transitions through the model, as Session::AddSamples and a
// lazy refit would.
void ModelTakes(const v1::SessionConfig& config,
                const google::protobuf::RepeatedPtrField<v1::Transition>& transitions) {
  absl::StatusOr<gp::DynamicsModel> model =
      gp::DynamicsModel::Create(ModelOptionsFromConfig(config));
  if (!model.ok()) std::abort();  // a validated config must make a model
  const int dx = config.state_dim();
  const int du = config.input_dim();
  const Eigen::Index n = transitions.size();
  Eigen::MatrixXd states(n, dx), inputs(n, du), next_states(n, dx);
  for (Eigen::Index i = 0; i < n; ++i) {
    const v1::Transition& t = transitions[static_cast<int>(i)];
    for (int j = 0; j < dx; ++j) {
      states(i, j) = t.state(j);
      next_states(i, j) = t.next_state(j);
    }
    for (int j = 0; j < du; ++j) inputs(i, j) = t.input(j);
  }
  if (!model->AddSamples(states, inputs, next_states).ok()) std::abort();
  if (n < 2) return;
  int evaluations = 0;  // a short fit: the fuzzer wants many inputs per second
  if (!model->Refit([&evaluations]() { return ++evaluations > 5; }).ok()) std::abort();
  Eigen::MatrixXd z(n, dx + du);
  z << states, inputs;
  Eigen::MatrixXd mean, variance;
  model->Predict(z, &mean, &variance, nullptr, nullptr);
  if (!mean.allFinite() || !variance.allFinite()) std::abort();
}

// What an accepted import stores converts back to the wire (the creation time
// as a valid Timestamp), and its export imports again: no stored value may make
// a later ListSessions, GetSession or ExportSession fail.
void StoredReadsBack(const v1::SessionArchive& archive, const v1::SessionConfig& config) {
  const ArchiveRecords records = ArchiveToStore(archive, config, /*now_unix_ms=*/1);
  const int64_t created = WireUnixMs(records.record.created_unix_ms);
  if (created != records.record.created_unix_ms) std::abort();  // stored out of range
  // Out of Timestamp's range this CHECK-fails: the fuzzer reports the crash.
  (void)google::protobuf::util::TimeUtil::MillisecondsToTimestamp(created);
  v1::SessionArchive exported = ArchiveFromStore(records.record, records.samples);
  if (!ValidateSessionArchive(exported).ok()) std::abort();
}

void CheckRequests(const v1::SessionConfig& config, const std::string& bytes) {
  v1::AddDataRequest add;
  if (add.ParseFromString(bytes) &&
      ValidateTransitions({config.state_dim(), config.input_dim()}, add.transitions())
          .ok()) {
    ModelTakes(config, add.transitions());
  }
  v1::PredictRequest predict;
  if (predict.ParseFromString(bytes)) {
    (void)ValidatePredictInputs({config.state_dim(), config.input_dim()},
                                predict.inputs(), 1000);
  }
  v1::PlanInputsRequest plan;
  if (plan.ParseFromString(bytes)) {
    (void)ValidatePlanRequest({config.state_dim(), config.input_dim()}, config.horizon(),
                              plan);
  }
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
    // An archive is a config and transitions in one message: the fuzzer reaches
    // the model through it far more often than through a config and an
    // AddDataRequest parsed from the same bytes.
    absl::StatusOr<excite::v1::SessionConfig> config =
        excite::service::ValidateSessionArchive(archive);
    if (config.ok()) {
      excite::service::ModelTakes(*config, archive.samples());
      excite::service::StoredReadsBack(archive, *config);
    }
  }
  // ListSessions' label filter: parsed or refused, never a crash; a parsed one
  // can be applied.
  absl::StatusOr<excite::service::LabelFilter> filter =
      excite::service::LabelFilter::Parse(bytes);
  if (filter.ok()) filter->Matches({{"plant", "pendulum"}, {"", bytes}});
  return 0;
}
