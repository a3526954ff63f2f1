#include "server/service/store_conversion.h"

#include <algorithm>

#include "server/service/session_options.h"
#include "server/service/value_ranges.h"

namespace excite::service {

store::SampleRecord ToSampleRecord(const v1::Transition& transition) {
  store::SampleRecord record;
  record.sequence = transition.sequence();
  record.state.assign(transition.state().begin(), transition.state().end());
  record.input.assign(transition.input().begin(), transition.input().end());
  record.next_state.assign(transition.next_state().begin(),
                           transition.next_state().end());
  record.timestamp_s = transition.timestamp_s();
  return record;
}

v1::Transition ToTransition(const store::SampleRecord& sample) {
  v1::Transition transition;
  transition.set_sequence(sample.sequence);
  transition.mutable_state()->Add(sample.state.begin(), sample.state.end());
  transition.mutable_input()->Add(sample.input.begin(), sample.input.end());
  transition.mutable_next_state()->Add(sample.next_state.begin(),
                                       sample.next_state.end());
  transition.set_timestamp_s(sample.timestamp_s);
  return transition;
}

int64_t WireUnixMs(int64_t stored_unix_ms) {
  return std::clamp<int64_t>(stored_unix_ms, 0, kMaxUnixMs);
}

std::string EncodeSavedHyperparameters(
    const google::protobuf::RepeatedPtrField<v1::Hyperparameters>& hyperparameters,
    int64_t fitted_samples) {
  v1::Session saved;
  saved.set_sample_count(fitted_samples);
  for (const v1::Hyperparameters& h : hyperparameters) {
    *saved.add_outputs()->mutable_hyperparameters() = h;
  }
  return saved.SerializeAsString();
}

std::optional<ArchivedFit> DecodeSavedHyperparameters(const std::string& bytes) {
  v1::Session saved;
  if (!saved.ParseFromString(bytes)) return std::nullopt;
  ArchivedFit result;
  result.fitted_samples = saved.sample_count();
  result.hyperparameters.reserve(static_cast<size_t>(saved.outputs_size()));
  for (const v1::OutputModel& output : saved.outputs()) {
    result.hyperparameters.push_back(output.hyperparameters());
  }
  return result;
}

absl::StatusOr<session::SessionSpec> ProtoStoredFormat::DecodeConfig(
    const std::string& bytes) const {
  v1::SessionConfig config;
  if (!config.ParseFromString(bytes)) {
    return absl::DataLossError("the stored config does not parse");
  }
  session::SessionSpec spec = SessionSpecFromConfig(config);
  spec.config = bytes;  // as stored
  return spec;
}

std::string ProtoStoredFormat::EncodeFit(const session::SavedFit& fit) const {
  google::protobuf::RepeatedPtrField<v1::Hyperparameters> protos;
  for (const gp::Hyperparameters& h : fit.hyperparameters) *protos.Add() = ToProto(h);
  return EncodeSavedHyperparameters(protos, fit.fitted_samples);
}

std::optional<session::SavedFit> ProtoStoredFormat::DecodeFit(const std::string& bytes,
                                                              int state_dim,
                                                              int kernel_inputs) const {
  std::optional<ArchivedFit> saved = DecodeSavedHyperparameters(bytes);
  if (!saved.has_value() || saved->hyperparameters.empty() ||
      static_cast<int>(saved->hyperparameters.size()) != state_dim) {
    return std::nullopt;
  }
  session::SavedFit result;
  result.fitted_samples = saved->fitted_samples;
  for (const v1::Hyperparameters& h : saved->hyperparameters) {
    if (h.lengthscales_size() != kernel_inputs) return std::nullopt;
    result.hyperparameters.push_back(FromProto(h));
  }
  return result;
}

}  // namespace excite::service
