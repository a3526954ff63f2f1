#ifndef EXCITE_CLIENT_TRANSITION_CSV_H_
#define EXCITE_CLIENT_TRANSITION_CSV_H_

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "excite/v1/exploration_service.pb.h"

namespace excite::client {

// The one CSV layout of transitions, read by `excite add` and written by
// `excite-sim --trajectory`: one row per transition, comma-separated,
//   x0..x{dx-1}, u0..u{du-1}, x0_next..x{dx-1}_next[, sequence]
// under a header naming those columns. sequence is the transition's integer
// sequence number (AddData's idempotency key); without it `excite add` numbers
// rows after the session's last sequence. Blank lines and '#' comments are
// skipped.

// The header line (no newline) for state_dim dx and input_dim du, with the
// sequence column: the config's dimension names when given (dx and du of them;
// "theta,theta_dot,tau,theta_next,theta_dot_next,sequence"), else x0.., u0...
std::string TransitionCsvHeader(int dx, int du,
                                const std::vector<std::string>& state_names = {},
                                const std::vector<std::string>& input_names = {});
// One row (no newline), every number to 17 significant digits (exact).
std::string TransitionCsvRow(const v1::Transition& transition);

// Whether the first row is a header. kAuto: it is if every field is a name (starts
// with a letter or '_' and does not parse as a number); a row with some numbers
// is data, so a mistyped number is an error, not a skipped header.
enum class CsvHeader { kAuto, kYes, kNo };
// "auto", "yes" or "no"; INVALID_ARGUMENT otherwise.
absl::StatusOr<CsvHeader> ParseCsvHeaderMode(absl::string_view text);

// The transitions of `text`, numbered from `next_sequence` where a row has no
// sequence. INVALID_ARGUMENT naming the line ("line 3: ...") for a row that is
// not 2 dx + du numbers plus an optional integer sequence, for a sequence that
// two rows share, and if there is no transition at all.
absl::StatusOr<std::vector<v1::Transition>> ParseTransitionCsv(absl::string_view text,
                                                               int dx, int du,
                                                               int64_t next_sequence,
                                                               CsvHeader header);

}  // namespace excite::client

#endif  // EXCITE_CLIENT_TRANSITION_CSV_H_
