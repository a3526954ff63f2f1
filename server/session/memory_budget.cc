#include "server/session/memory_budget.h"

#include <malloc.h>
#include <unistd.h>

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "server/session/machine_limits.h"

namespace excite::session {

absl::Status MemoryBudget::Reserve(int64_t bytes, absl::string_view what) {
  int64_t used = used_.load();
  do {
    if (bytes > 0 && used + bytes > limit_) {
      return absl::ResourceExhaustedError(absl::StrCat(
          what, " would take an estimated ", FormatBytes(bytes), " more memory; ",
          FormatBytes(used), " of the server's budget of ", FormatBytes(limit_),
          " is in use (raise --memory_budget_mb on a machine with more memory, or "
          "delete sessions no longer needed)"));
    }
  } while (!used_.compare_exchange_weak(used, used + bytes));
  return absl::OkStatus();
}

int64_t DefaultMemoryBudgetBytes() {
  const long pages = sysconf(_SC_PHYS_PAGES);
  const long page_size = sysconf(_SC_PAGE_SIZE);
  int64_t available =
      pages > 0 && page_size > 0 ? int64_t{pages} * page_size : int64_t{1} << 30;
  for (const char* path :
       {"/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"}) {
    if (const int64_t limit = ReadLimitFile(path); limit > 0) {
      available = std::min(available, limit);
    }
  }
  return available / 4 * 3;
}

std::string FormatBytes(int64_t bytes) {
  const double b = static_cast<double>(bytes);
  if (b >= 1024.0 * 1024 * 1024) return absl::StrFormat("%.1f GiB", b / (1 << 30));
  if (b >= 1024.0 * 1024 * 10) return absl::StrFormat("%.0f MiB", b / (1 << 20));
  return absl::StrFormat("%.1f MiB", b / (1 << 20));
}

void ReturnFreedMemory() { malloc_trim(0); }

}  // namespace excite::session
