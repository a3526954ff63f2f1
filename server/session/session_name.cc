#include "server/session/session_name.h"

#include "absl/strings/str_cat.h"

namespace excite::session {

bool IsValidSessionId(absl::string_view id) {
  if (id.empty() || id.size() > 63) return false;
  for (char c : id) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-';
    if (!ok) return false;
  }
  return true;
}

std::string SessionName(absl::string_view id) { return absl::StrCat("sessions/", id); }

}  // namespace excite::session
