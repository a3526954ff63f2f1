#ifndef EXCITE_SERVER_SESSION_SESSION_NAME_H_
#define EXCITE_SERVER_SESSION_SESSION_NAME_H_

#include <string>

#include "absl/strings/string_view.h"

namespace excite::session {

// True for a valid session id: 1 to 63 characters of [a-z0-9-].
bool IsValidSessionId(absl::string_view id);

// "sessions/{id}", the name every message about a session uses.
std::string SessionName(absl::string_view id);

}  // namespace excite::session

#endif  // EXCITE_SERVER_SESSION_SESSION_NAME_H_
