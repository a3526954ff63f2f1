#include "server/service/field_violation.h"

#include "absl/strings/cord.h"
#include "absl/strings/str_cat.h"

namespace excite::service {
namespace {

// Payload type URL; the payload is the field path as plain bytes.
constexpr absl::string_view kFieldPayload = "type.excite.dev/excite.FieldPath";

}  // namespace

absl::Status FieldViolationError(absl::string_view field, absl::string_view description) {
  absl::Status status =
      absl::InvalidArgumentError(absl::StrCat(field, ": ", description));
  status.SetPayload(kFieldPayload, absl::Cord(field));
  return status;
}

std::optional<std::string> ViolatedField(const absl::Status& status) {
  const auto payload = status.GetPayload(kFieldPayload);  // absl::optional
  if (!payload.has_value()) return std::nullopt;
  return std::string(*payload);
}

absl::Status WithMessage(const absl::Status& status, absl::string_view message) {
  if (status.ok()) return status;
  absl::Status result(status.code(), message);
  status.ForEachPayload([&result](absl::string_view type_url, const absl::Cord& payload) {
    result.SetPayload(type_url, payload);
  });
  return result;
}

}  // namespace excite::service
