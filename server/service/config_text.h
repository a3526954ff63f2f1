#ifndef EXCITE_SERVER_SERVICE_CONFIG_TEXT_H_
#define EXCITE_SERVER_SERVICE_CONFIG_TEXT_H_

#include <string>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "excite/v1/session_config.pb.h"
#include "google/protobuf/message.h"

namespace excite::service {

// Parses protobuf text format into `message`: INVALID_ARGUMENT with every error
// as "line:column: message" (an unknown enum value also lists the valid ones).
// Enum values may also be written by their short names in any case, as
// everywhere else in excite: "strategy: rec" is "strategy: STRATEGY_REC".
// The one text-format parser of the project (config files, excite-sim, the CLI).
absl::Status ParseTextProto(absl::string_view text, google::protobuf::Message* message);

// The whole file at `path`; NOT_FOUND "cannot read PATH" if it cannot be read.
absl::StatusOr<std::string> ReadTextFile(const std::string& path);

// Parses a SessionConfig in protobuf text format. INVALID_ARGUMENT with
// protobuf's "line:column: message" if it does not parse. Does not validate: call
// ValidateSessionConfig (config_validation.h).
absl::StatusOr<v1::SessionConfig> ParseSessionConfigText(absl::string_view text);

// Reads and parses a textproto file holding a SessionConfig, or a SimConfig
// (sim/configs), whose `session` it returns. NOT_FOUND if it cannot be read,
// INVALID_ARGUMENT with both parsers' errors if it is neither.
absl::StatusOr<v1::SessionConfig> LoadSessionConfigFile(const std::string& path);

}  // namespace excite::service

#endif  // EXCITE_SERVER_SERVICE_CONFIG_TEXT_H_
