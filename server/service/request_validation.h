#ifndef EXCITE_SERVER_SERVICE_REQUEST_VALIDATION_H_
#define EXCITE_SERVER_SERVICE_REQUEST_VALIDATION_H_

#include <cstdint>

#include "absl/status/status.h"
#include "absl/strings/string_view.h"
#include "excite/v1/exploration_service.pb.h"
#include "excite/v1/session_config.pb.h"
#include "google/protobuf/repeated_field.h"
#include "server/session/session_spec.h"

namespace excite::service {

// A session's dimensions, what a request's numbers are checked against.
struct Dims {
  int state_dim = 0;
  int input_dim = 0;
};
inline Dims DimsOf(const session::SessionSpec& spec) {
  return {spec.state_dim, spec.input_dim};
}

// Checks one AddData message's transitions against a (validated) session config:
// state/next_state of state_dim and input of input_dim numbers, all finite and
// within +-kMaxAbsValue (value_ranges.h); sequence in [0, kMaxSequence];
// finite timestamp_s; no sequence number twice in the message.
// INVALID_ARGUMENT naming the field under `field`, e.g.
// "transitions[3].state[1]: ..." (a SessionArchive's samples: "archive.samples").
absl::Status ValidateTransitions(
    const Dims& dims,
    const google::protobuf::RepeatedPtrField<v1::Transition>& transitions,
    absl::string_view field = "transitions");

// Checks a Predict batch: non-empty, a multiple of state_dim + input_dim numbers,
// all finite and within +-kMaxAbsValue (INVALID_ARGUMENT naming "inputs"); at most
// `max_points` points (RESOURCE_EXHAUSTED).
absl::Status ValidatePredictInputs(const Dims& dims,
                                   const google::protobuf::RepeatedField<double>& inputs,
                                   int64_t max_points);

// Checks a PlanInputs request: state_dim finite numbers within +-kMaxAbsValue
// (INVALID_ARGUMENT "state"); pending_inputs 0 to `horizon` steps of input_dim
// numbers, in range (INVALID_ARGUMENT naming "pending_inputs").
absl::Status ValidatePlanRequest(const Dims& dims, int horizon,
                                 const v1::PlanInputsRequest& request);

// Steps of one Rollout call (each a one-point prediction with Jacobians, O(n^2)).
inline constexpr int kMaxRolloutSteps = 1000;

// Checks a Rollout request: state as for PlanInputs; state_variance empty or
// state_dim numbers >= 0; inputs 1 to kMaxRolloutSteps steps of input_dim
// numbers, in range. INVALID_ARGUMENT naming the field.
absl::Status ValidateRollout(const Dims& dims, const v1::RolloutRequest& request);

}  // namespace excite::service

#endif  // EXCITE_SERVER_SERVICE_REQUEST_VALIDATION_H_
