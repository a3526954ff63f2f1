#include "server/session/machine_limits.h"

#include <sched.h>

#include <algorithm>
#include <fstream>
#include <string>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_split.h"

namespace excite::session {
namespace {

int CeilDiv(int64_t quota, int64_t period) {
  return static_cast<int>(std::min<int64_t>((quota + period - 1) / period, 1 << 20));
}

}  // namespace

int64_t ReadLimitFile(const char* path) {
  std::ifstream in(path);
  std::string text;
  if (!std::getline(in, text)) return 0;
  int64_t value = 0;
  if (!absl::SimpleAtoi(absl::StripAsciiWhitespace(text), &value) || value <= 0) return 0;
  // cgroup v1 reports "no limit" as a huge page-rounded number.
  if (value >= (int64_t{1} << 60)) return 0;
  return value;
}

int CoresFromCpuMax(absl::string_view line) {
  const std::vector<absl::string_view> fields =
      absl::StrSplit(absl::StripAsciiWhitespace(line), ' ', absl::SkipEmpty());
  int64_t quota = 0;
  int64_t period = 0;
  if (fields.size() != 2 || !absl::SimpleAtoi(fields[0], &quota) ||
      !absl::SimpleAtoi(fields[1], &period) || quota <= 0 || period <= 0) {
    return 0;  // "max PERIOD" included
  }
  return CeilDiv(quota, period);
}

int AvailableCores() {
  int cores = 1;
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof(set), &set) == 0) cores = std::max(1, CPU_COUNT(&set));
  int quota_cores = 0;
  std::ifstream v2("/sys/fs/cgroup/cpu.max");
  if (std::string line; std::getline(v2, line)) {
    quota_cores = CoresFromCpuMax(line);
  } else {
    const int64_t quota = ReadLimitFile("/sys/fs/cgroup/cpu/cpu.cfs_quota_us");
    const int64_t period = ReadLimitFile("/sys/fs/cgroup/cpu/cpu.cfs_period_us");
    if (quota > 0 && period > 0) quota_cores = CeilDiv(quota, period);
  }
  if (quota_cores > 0) cores = std::min(cores, quota_cores);
  return cores;
}

}  // namespace excite::session
