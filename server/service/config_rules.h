#ifndef EXCITE_SERVER_SERVICE_CONFIG_RULES_H_
#define EXCITE_SERVER_SERVICE_CONFIG_RULES_H_

#include <string>

#include "absl/status/status.h"
#include "absl/strings/string_view.h"
#include "absl/types/span.h"
#include "excite/v1/session_config.pb.h"
#include "server/service/field_violation.h"

namespace excite::service {

// The rules of SessionConfig's scalar numbers whose 0 (proto3's "unset") means a
// default, as data: the checks, the defaults filled in and the API reference's
// table (docs/api-reference.md, "SessionConfig numbers") all come from here.
// Rules that relate fields (dimensions, bounds, presence) stay in
// config_validation.cc.
struct NumberRule {
  // Path under SessionConfig, e.g. "planner.max_iterations" (an int32 or a
  // double field).
  absl::string_view path;
  // What 0 means; always within the range.
  double default_value = 0.0;
  // The valid range of the value (after the default is filled in).
  double min = 0.0;
  double max = 0.0;
  bool min_open = false;   // (min, ... instead of [min, ...
  bool max_open = false;   // ..., max) instead of ..., max]
  absl::string_view unit;  // " seconds", " cycles per sample", or empty
  // Whose defaults these are filled in for: empty for every session, a
  // strategy's short name ("prbs": only its sessions, so other sessions' stored
  // configs do not change), or "sparse" (only when sparse.above_samples > 0).
  absl::string_view filled_for;
  // Where the default and the range come from (one line, for the docs).
  absl::string_view why;
};

// Every rule, in the order the checks report problems.
absl::Span<const NumberRule> NumberRules();

// Checks every rule's field of `config` (a 0 is the default, whatever the
// strategy; a set value must be in range) and fills the defaults of the rules
// whose filled_for applies (call it once the strategy and
// sparse.above_samples are settled). Adds one FieldViolationError per field
// out of range (field "<path>.<rule path>") to `problems`, in table order.
void ApplyNumberRules(v1::SessionConfig* config, absl::string_view path,
                      Violations* problems);

// The rules as a Markdown table (field, default, range, filled for, why): the
// API reference's section, generated from the same data.
std::string NumberRulesMarkdown();

}  // namespace excite::service

#endif  // EXCITE_SERVER_SERVICE_CONFIG_RULES_H_
