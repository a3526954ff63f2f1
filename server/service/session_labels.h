#ifndef EXCITE_SERVER_SERVICE_SESSION_LABELS_H_
#define EXCITE_SERVER_SERVICE_SESSION_LABELS_H_

#include <map>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "google/protobuf/map.h"
#include "server/session/labels.h"

namespace excite::service {

using session::Labels;

// A session's display name (at most 256 characters, no control characters) and
// labels (at most 64; keys 1-63 of [a-z0-9_-] starting with a letter, values 0-63
// of [a-z0-9_-]). INVALID_ARGUMENT with one field violation per problem, the
// fields named under `prefix` ("" or e.g. "archive.").
absl::Status ValidateDisplayNameAndLabels(
    const std::string& display_name,
    const google::protobuf::Map<std::string, std::string>& labels,
    absl::string_view prefix = "");

// ListSessions' filter: conditions joined by AND, each `labels.KEY = "VALUE"`
// (VALUE may be unquoted), `labels.KEY != "VALUE"` or `labels.KEY:*`. A missing
// key matches no `=` and every `!=`.
class LabelFilter {
 public:
  // INVALID_ARGUMENT on field "filter" saying what is wrong and what is allowed.
  // An empty (or blank) filter matches every session.
  static absl::StatusOr<LabelFilter> Parse(absl::string_view filter);
  bool Matches(const Labels& labels) const;

 private:
  enum class Op { kEquals, kNotEquals, kHas };
  struct Condition {
    std::string key;
    Op op;
    std::string value;
  };
  std::vector<Condition> conditions_;
};

}  // namespace excite::service

#endif  // EXCITE_SERVER_SERVICE_SESSION_LABELS_H_
