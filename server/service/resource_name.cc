#include "server/service/resource_name.h"

#include "absl/status/status.h"
#include "absl/strings/escaping.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "server/service/field_violation.h"

namespace excite::service {
namespace {
constexpr absl::string_view kPrefix = "sessions/";
}  // namespace

absl::Status CheckOptionalSessionId(absl::string_view id, absl::string_view field) {
  if (id.empty() || IsValidSessionId(id)) return absl::OkStatus();
  return FieldViolationError(field,
                             absl::StrCat("\"", absl::CHexEscape(id.substr(0, 100)),
                                          "\" must be 1 to 63 characters [a-z0-9-]"));
}

absl::StatusOr<std::string> ParseSessionName(absl::string_view name,
                                             absl::string_view field) {
  if (name.empty()) {
    return FieldViolationError(field, "required (a session name \"sessions/{id}\")");
  }
  if (!absl::StartsWith(name, kPrefix) ||
      !IsValidSessionId(name.substr(kPrefix.size()))) {
    return FieldViolationError(
        field, absl::StrCat("\"", absl::CHexEscape(name.substr(0, 200)),
                            "\" is not a session name \"sessions/{id}\" with id of 1 to "
                            "63 characters [a-z0-9-]"));
  }
  return std::string(name.substr(kPrefix.size()));
}

}  // namespace excite::service
