#ifndef EXCITE_BENCH_LOAD_LOAD_STATS_H_
#define EXCITE_BENCH_LOAD_LOAD_STATS_H_

#include <sys/types.h>

#include <algorithm>
#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"

namespace excite::bench {

// VmRSS of `pid` in KiB, -1 if unreadable.
inline int64_t RssKib(pid_t pid) {
  std::ifstream in(absl::StrCat("/proc/", pid, "/status"));
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("VmRSS:", 0) == 0) {
      int64_t kib = -1;
      std::string digits;
      for (char c : line) {
        if (c >= '0' && c <= '9') digits += c;
      }
      return absl::SimpleAtoi(digits, &kib) ? kib : -1;
    }
  }
  return -1;
}

// The `q` quantile of `values` (nearest rank); 0 if empty.
inline double Percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  const size_t i =
      std::min(values.size() - 1,
               static_cast<size_t>(q * static_cast<double>(values.size() - 1) + 0.5));
  return values[i];
}

}  // namespace excite::bench

#endif  // EXCITE_BENCH_LOAD_LOAD_STATS_H_
