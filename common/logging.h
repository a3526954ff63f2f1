#ifndef EXCITE_COMMON_LOGGING_H_
#define EXCITE_COMMON_LOGGING_H_

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace excite {

// A tiny leveled logger writing one line per message to stderr (Abseil 20220623
// has no absl/log). Thread-safe.
enum class LogLevel { kDebug = 0, kInfo = 1, kWarning = 2, kError = 3 };

// Messages below `level` are dropped. Default: kInfo.
void SetLogLevel(LogLevel level);
LogLevel GetLogLevel();
bool LogEnabled(LogLevel level);

// "debug", "info", "warning", "error" (case-insensitive). INVALID_ARGUMENT
// otherwise.
absl::StatusOr<LogLevel> ParseLogLevel(absl::string_view name);

// Writes "<UTC time> <D|I|W|E> <message>\n" if `level` is enabled.
void Log(LogLevel level, absl::string_view message);

}  // namespace excite

#endif  // EXCITE_COMMON_LOGGING_H_
