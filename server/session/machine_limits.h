#ifndef EXCITE_SERVER_SESSION_MACHINE_LIMITS_H_
#define EXCITE_SERVER_SESSION_MACHINE_LIMITS_H_

#include <cstdint>

#include "absl/strings/string_view.h"

namespace excite::session {

// What the machine, and the cgroup the process runs in, let it use.

// The number in a one-line file (a cgroup limit); 0 if the file is absent, or
// holds "max", a negative number (v1's "no limit") or an absurd one.
int64_t ReadLimitFile(const char* path);

// The cores this process may use: the CPUs of its affinity mask, capped by the
// cgroup's CPU quota (v2 cpu.max, v1 cpu.cfs_quota_us over cpu.cfs_period_us),
// rounded up. At least 1.
int AvailableCores();

// Cores that a cgroup v2 cpu.max line ("QUOTA PERIOD", or "max PERIOD") allows,
// rounded up; 0 if it sets no limit or does not parse.
int CoresFromCpuMax(absl::string_view line);

}  // namespace excite::session

#endif  // EXCITE_SERVER_SESSION_MACHINE_LIMITS_H_
