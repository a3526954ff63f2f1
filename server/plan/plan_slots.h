#ifndef EXCITE_SERVER_PLAN_PLAN_SLOTS_H_
#define EXCITE_SERVER_PLAN_PLAN_SLOTS_H_

#include <chrono>
#include <functional>
#include <optional>

#include "absl/status/status.h"

namespace excite::plan {

// How many model-based plans run at once in the process (a plan holds a slot from
// its first rollout to its end). Plans beyond the cores would only share them:
// a thread preempted while it holds the MUMPS or BLAS lock
// (ipopt_library_calls.h) stalls every other solve, so more running plans than
// cores plan fewer per second
// (docs/parallel-planning.md).

// At least 1; 1 until set. Set once at start (excite-server's --planner_workers).
void SetConcurrentPlans(int plans);
int ConcurrentPlans();

// A slot for one plan, held for the object's lifetime once Acquire() succeeded.
class PlanSlot {
 public:
  PlanSlot() = default;
  ~PlanSlot();
  PlanSlot(const PlanSlot&) = delete;
  PlanSlot& operator=(const PlanSlot&) = delete;

  // Waits for a free slot, served in arrival order. DEADLINE_EXCEEDED if none came free
  // before `deadline` (a free slot is taken also after it), CANCELLED once `cancelled()`
  // is true (checked every 20 ms), without a slot then. On a thread that holds a slot
  // already (a plan inside a plan, as auto's members), OK at once and nothing more is
  // taken.
  absl::Status Acquire(std::optional<std::chrono::steady_clock::time_point> deadline,
                       const std::function<bool()>& cancelled);
  // Takes a slot only if one is free now and no plan waits for one (a helper
  // thread of a plan that holds a slot already: the work it would take over is
  // otherwise done by its caller). False, without a slot, on a thread that holds
  // one.
  bool TryAcquire();

 private:
  bool held_ = false;
};

}  // namespace excite::plan

#endif  // EXCITE_SERVER_PLAN_PLAN_SLOTS_H_
