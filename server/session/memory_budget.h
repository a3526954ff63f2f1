#ifndef EXCITE_SERVER_SESSION_MEMORY_BUDGET_H_
#define EXCITE_SERVER_SESSION_MEMORY_BUDGET_H_

#include <atomic>
#include <cstdint>
#include <string>

#include "absl/status/status.h"
#include "absl/strings/string_view.h"

namespace excite::session {

// The server's memory budget: the sum of every session's estimated peak memory
// (Session::EstimatedBytes) against one limit, so that a request that would take
// more than the machine has is refused (RESOURCE_EXHAUSTED) instead of getting
// the server OOM-killed. Thread-safe.
class MemoryBudget {
 public:
  // `limit_bytes` > 0.
  explicit MemoryBudget(int64_t limit_bytes) : limit_(limit_bytes) {}
  MemoryBudget(const MemoryBudget&) = delete;
  MemoryBudget& operator=(const MemoryBudget&) = delete;

  // Takes `bytes` more if they fit; otherwise RESOURCE_EXHAUSTED saying that
  // `what` would take them, and what is in use and allowed. Nothing taken then.
  absl::Status Reserve(int64_t bytes, absl::string_view what);
  // Takes `bytes` whether or not they fit: sessions restored at start, which are
  // already stored (the budget then refuses growth until enough is released).
  void ForceReserve(int64_t bytes) { used_ += bytes; }
  void Release(int64_t bytes) { used_ -= bytes; }

  int64_t used() const { return used_.load(); }
  int64_t limit() const { return limit_; }

 private:
  const int64_t limit_;
  std::atomic<int64_t> used_{0};
};

// The default budget: three quarters of the memory this process may use, the
// smaller of the cgroup's limit (v2 memory.max or v1 memory.limit_in_bytes) and
// the machine's physical memory. The last quarter is room for what the estimate
// leaves out: the process itself, gRPC's message buffers, Predict's chunks and
// planning.
int64_t DefaultMemoryBudgetBytes();

// "1.5 MiB", "918 MiB", "3.2 GiB".
std::string FormatBytes(int64_t bytes);

// Gives the free memory of every malloc arena back to the system (glibc's
// malloc_trim). Call where large blocks were just freed: after a refit (its n x n
// matrices) and after a session is dropped. Between calls, freed blocks stay in
// the arena of the thread that freed them and are reused without new page
// faults; without calls, each thread's arena would keep its own high-water mark
// of freed kernel matrices, so the process would hold more than the budget
// estimates. Costs a walk over the arenas' free blocks. Thread-safe.
void ReturnFreedMemory();

}  // namespace excite::session

#endif  // EXCITE_SERVER_SESSION_MEMORY_BUDGET_H_
