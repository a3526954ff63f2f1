#include "server/store/sample_rows.h"

#include <utility>

#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "server/store/double_blob.h"

namespace excite::store {

absl::Status AppendSampleRow(const std::string& session_id, int64_t sequence,
                             absl::string_view state, absl::string_view input,
                             absl::string_view next_state, double timestamp_s,
                             std::vector<SampleRecord>* samples,
                             std::vector<int64_t>* unreadable) {
  absl::StatusOr<std::vector<double>> decoded[3] = {
      DecodeDoubles(state), DecodeDoubles(input), DecodeDoubles(next_state)};
  for (const absl::StatusOr<std::vector<double>>& blob : decoded) {
    if (blob.ok()) continue;
    if (unreadable != nullptr) {
      unreadable->push_back(sequence);
      return absl::OkStatus();
    }
    return absl::DataLossError(absl::StrCat("session ", session_id, " sample ", sequence,
                                            ": ", blob.status().message()));
  }
  SampleRecord record;
  record.sequence = sequence;
  record.state = *std::move(decoded[0]);
  record.input = *std::move(decoded[1]);
  record.next_state = *std::move(decoded[2]);
  record.timestamp_s = timestamp_s;
  samples->push_back(std::move(record));
  return absl::OkStatus();
}

}  // namespace excite::store
