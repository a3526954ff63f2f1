#ifndef EXCITE_SERVER_STORE_SAMPLE_ROWS_H_
#define EXCITE_SERVER_STORE_SAMPLE_ROWS_H_

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/string_view.h"
#include "server/store/store_records.h"

namespace excite::store {

// One row of the samples table as both stores read it (sequence, the blobs of
// state, input and next_state, timestamp), decoded and appended to `samples`.
// A blob that does not decode (double_blob.h) is DATA_LOSS naming the session
// and the sequence, unless `unreadable` is given: then the row's sequence is
// appended there and the row skipped (OK).
absl::Status AppendSampleRow(const std::string& session_id, int64_t sequence,
                             absl::string_view state, absl::string_view input,
                             absl::string_view next_state, double timestamp_s,
                             std::vector<SampleRecord>* samples,
                             std::vector<int64_t>* unreadable);

}  // namespace excite::store

#endif  // EXCITE_SERVER_STORE_SAMPLE_ROWS_H_
