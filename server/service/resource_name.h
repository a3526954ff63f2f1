#ifndef EXCITE_SERVER_SERVICE_RESOURCE_NAME_H_
#define EXCITE_SERVER_SERVICE_RESOURCE_NAME_H_

#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "server/session/session_name.h"

namespace excite::service {

using session::IsValidSessionId;  // 1 to 63 characters of [a-z0-9-]
using session::SessionName;       // "sessions/{id}"

// OK if `id` is empty (the server picks one) or a valid id; otherwise
// INVALID_ARGUMENT naming `field`.
absl::Status CheckOptionalSessionId(absl::string_view id, absl::string_view field);

// The id of a resource name "sessions/{id}". INVALID_ARGUMENT naming `field` if
// `name` is not of that form.
absl::StatusOr<std::string> ParseSessionName(absl::string_view name,
                                             absl::string_view field);

}  // namespace excite::service

#endif  // EXCITE_SERVER_SERVICE_RESOURCE_NAME_H_
