#ifndef EXCITE_SERVER_SERVICE_FIELD_VIOLATION_H_
#define EXCITE_SERVER_SERVICE_FIELD_VIOLATION_H_

#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/string_view.h"

namespace excite::service {

// Validation errors carry the path of the offending field structurally, as an
// absl::Status payload, besides naming it in the message. ToGrpcStatus turns it
// into a google.rpc.BadRequest field violation (grpc-status-details-bin).

// INVALID_ARGUMENT "<field>: <description>" with `field` attached.
absl::Status FieldViolationError(absl::string_view field, absl::string_view description);

// The field attached by FieldViolationError (kept by WithMessage), if any.
std::optional<std::string> ViolatedField(const absl::Status& status);

// `status` with the same code and payloads and a new message. OK stays OK.
absl::Status WithMessage(const absl::Status& status, absl::string_view message);

struct FieldViolation {
  std::string field;
  std::string description;
};

// Every field violation `status` carries: the one of FieldViolationError, or
// each of a Violations::Result() with several. Empty if none.
std::vector<FieldViolation> FieldViolations(const absl::Status& status);

// How many problems a message of Violations::Result() spells out; the rest are
// counted ("... and K more"). ToGrpcStatus caps what reaches the wire again.
inline constexpr size_t kMaxListedProblems = 10;

// The problems of one request, so that it is refused with all of them at once:
// Add() each check's result. Result() is OK if none failed, the error itself if
// one did, else INVALID_ARGUMENT "N problems: <first>; <second>; ...; ... and K
// more" (the first kMaxListedProblems) carrying every field violation
// (FieldViolations).
class Violations {
 public:
  void Add(absl::Status status);
  bool empty() const { return errors_.empty(); }
  absl::Status Result() const;

 private:
  std::vector<absl::Status> errors_;
};

}  // namespace excite::service

#endif  // EXCITE_SERVER_SERVICE_FIELD_VIOLATION_H_
