#ifndef EXCITE_SERVER_STORE_DOUBLE_BLOB_H_
#define EXCITE_SERVER_STORE_DOUBLE_BLOB_H_

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace excite::store {

// Vectors of doubles as the stores keep them (SQLite blobs, PostgreSQL bytea):
// IEEE-754 little-endian doubles, nothing around them. Exact by construction.
std::string EncodeDoubles(const std::vector<double>& values);
// DATA_LOSS if the size is not a multiple of 8.
absl::StatusOr<std::vector<double>> DecodeDoubles(absl::string_view bytes);

}  // namespace excite::store

#endif  // EXCITE_SERVER_STORE_DOUBLE_BLOB_H_
