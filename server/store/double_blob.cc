#include "server/store/double_blob.h"

#include <cstring>

#include "absl/strings/str_cat.h"

namespace excite::store {

static_assert(sizeof(double) == 8, "the store's blob format needs 64-bit doubles");
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__
#error "the store's blob format is little-endian; add byte swapping for this host"
#endif

std::string EncodeDoubles(const std::vector<double>& values) {
  std::string bytes(values.size() * sizeof(double), '\0');
  if (!values.empty()) std::memcpy(bytes.data(), values.data(), bytes.size());
  return bytes;
}

absl::StatusOr<std::vector<double>> DecodeDoubles(absl::string_view bytes) {
  if (bytes.size() % sizeof(double) != 0) {
    return absl::DataLossError(absl::StrCat("a blob of doubles has ", bytes.size(),
                                            " bytes, not a multiple of 8"));
  }
  std::vector<double> values(bytes.size() / sizeof(double));
  if (!values.empty()) std::memcpy(values.data(), bytes.data(), bytes.size());
  return values;
}

}  // namespace excite::store
