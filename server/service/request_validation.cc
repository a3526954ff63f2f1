#include "server/service/request_validation.h"

#include <cmath>
#include <string>

#include "absl/container/flat_hash_map.h"
#include "absl/strings/str_cat.h"
#include "server/service/field_violation.h"
#include "server/service/value_ranges.h"

namespace excite::service {
namespace {

// A finite number within +-kMaxAbsValue (value_ranges.h: what the model can
// compute with).
bool InRange(double value) {
  return std::isfinite(value) && std::abs(value) <= kMaxAbsValue;
}

std::string OutOfRange(double value) {
  return absl::StrCat("must be finite and within +-", kMaxAbsValue, ", got ", value);
}

absl::Status CheckVector(absl::string_view field,
                         const google::protobuf::RepeatedField<double>& values,
                         int expected_size, absl::string_view size_name) {
  if (values.size() != expected_size) {
    return FieldViolationError(field,
                               absl::StrCat("must have ", size_name, " (", expected_size,
                                            ") numbers, got ", values.size()));
  }
  for (int i = 0; i < values.size(); ++i) {
    if (!InRange(values[i])) {
      return FieldViolationError(absl::StrCat(field, "[", i, "]"), OutOfRange(values[i]));
    }
  }
  return absl::OkStatus();
}

// `values`: min_steps to max_steps rows of `width` numbers, each in range; the
// limit is named as `max_name`.
absl::Status CheckSteps(absl::string_view field,
                        const google::protobuf::RepeatedField<double>& values, int width,
                        int min_steps, int max_steps, absl::string_view max_name) {
  const int steps = width > 0 ? values.size() / width : 0;
  if (width <= 0 || values.size() % width != 0 || steps < min_steps ||
      steps > max_steps) {
    return FieldViolationError(
        field, absl::StrCat("must hold ", min_steps, " to ", max_steps, " steps (",
                            max_name, ") of input_dim (", width, ") numbers, got ",
                            values.size(), " numbers"));
  }
  for (int i = 0; i < values.size(); ++i) {
    if (!InRange(values[i])) {
      return FieldViolationError(
          absl::StrCat(field, "[", i, "]"),
          absl::StrCat("(step ", i / width, ") ", OutOfRange(values[i])));
    }
  }
  return absl::OkStatus();
}

}  // namespace

absl::Status ValidateTransitions(
    const Dims& dims,
    const google::protobuf::RepeatedPtrField<v1::Transition>& transitions,
    absl::string_view field) {
  absl::flat_hash_map<int64_t, int> first_index;
  first_index.reserve(transitions.size());
  for (int i = 0; i < transitions.size(); ++i) {
    const v1::Transition& t = transitions[i];
    const std::string path = absl::StrCat(field, "[", i, "]");
    if (absl::Status s = CheckVector(absl::StrCat(path, ".state"), t.state(),
                                     dims.state_dim, "state_dim");
        !s.ok()) {
      return s;
    }
    if (absl::Status s = CheckVector(absl::StrCat(path, ".input"), t.input(),
                                     dims.input_dim, "input_dim");
        !s.ok()) {
      return s;
    }
    if (absl::Status s = CheckVector(absl::StrCat(path, ".next_state"), t.next_state(),
                                     dims.state_dim, "state_dim");
        !s.ok()) {
      return s;
    }
    if (t.sequence() < 0) {
      return FieldViolationError(absl::StrCat(path, ".sequence"),
                                 absl::StrCat("must be >= 0, got ", t.sequence()));
    }
    if (t.sequence() > kMaxSequence) {
      return FieldViolationError(
          absl::StrCat(path, ".sequence"),
          absl::StrCat("must be at most 2^53 = ", kMaxSequence,
                       " (what a JSON number holds exactly), got ", t.sequence()));
    }
    if (!std::isfinite(t.timestamp_s())) {
      return FieldViolationError(absl::StrCat(path, ".timestamp_s"),
                                 absl::StrCat("must be finite, got ", t.timestamp_s()));
    }
    auto [it, inserted] = first_index.emplace(t.sequence(), i);
    if (!inserted) {
      return FieldViolationError(
          absl::StrCat(path, ".sequence"),
          absl::StrCat(t.sequence(), " appears twice in one message (also in ", field,
                       "[", it->second, "])"));
    }
  }
  return absl::OkStatus();
}

absl::Status ValidatePredictInputs(const Dims& dims,
                                   const google::protobuf::RepeatedField<double>& inputs,
                                   int64_t max_points) {
  const int z_dim = dims.state_dim + dims.input_dim;
  if (inputs.empty()) {
    return FieldViolationError(
        "inputs", absl::StrCat("must hold at least one point z = (x, u) of state_dim + "
                               "input_dim (",
                               z_dim, ") numbers"));
  }
  if (inputs.size() % z_dim != 0) {
    return FieldViolationError(
        "inputs", absl::StrCat(inputs.size(),
                               " numbers is not a multiple of state_dim + input_dim (",
                               z_dim, ")"));
  }
  const int64_t points = inputs.size() / z_dim;
  if (points > max_points) {
    return absl::ResourceExhaustedError(absl::StrCat("inputs: ", points,
                                                     " points exceed the cap of ",
                                                     max_points, " per Predict call"));
  }
  for (int i = 0; i < inputs.size(); ++i) {
    if (!InRange(inputs[i])) {
      return FieldViolationError(
          absl::StrCat("inputs[", i, "]"),
          absl::StrCat("(point ", i / z_dim, ") ", OutOfRange(inputs[i])));
    }
  }
  return absl::OkStatus();
}

absl::Status ValidatePlanRequest(const Dims& dims, int horizon,
                                 const v1::PlanInputsRequest& request) {
  if (absl::Status s = CheckVector("state", request.state(), dims.state_dim, "state_dim");
      !s.ok()) {
    return s;
  }
  return CheckSteps("pending_inputs", request.pending_inputs(), dims.input_dim, 0,
                    horizon, "the session's horizon");
}

absl::Status ValidateRollout(const Dims& dims, const v1::RolloutRequest& request) {
  if (absl::Status s = CheckVector("state", request.state(), dims.state_dim, "state_dim");
      !s.ok()) {
    return s;
  }
  if (!request.state_variance().empty()) {
    if (absl::Status s = CheckVector("state_variance", request.state_variance(),
                                     dims.state_dim, "state_dim (or none)");
        !s.ok()) {
      return s;
    }
    for (int i = 0; i < request.state_variance_size(); ++i) {
      if (request.state_variance(i) < 0) {
        return FieldViolationError(absl::StrCat("state_variance[", i, "]"),
                                   "a variance cannot be negative");
      }
    }
  }
  return CheckSteps("inputs", request.inputs(), dims.input_dim, 1, kMaxRolloutSteps,
                    "a rollout's limit");
}

}  // namespace excite::service
