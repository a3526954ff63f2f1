#include "server/plan/plan_slots.h"

#include <algorithm>

#include "absl/base/thread_annotations.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"

namespace excite::plan {
namespace {

// A counting semaphore (C++17 has none).
class Slots {
 public:
  void SetLimit(int limit) {
    absl::MutexLock lock(&mu_);
    limit_ = std::max(1, limit);
  }
  int limit() {
    absl::MutexLock lock(&mu_);
    return limit_;
  }
  // True with a slot taken, false if `until` came first.
  bool TakeBefore(absl::Time until) {
    absl::MutexLock lock(&mu_);
    if (!mu_.AwaitWithDeadline(absl::Condition(this, &Slots::Free), until)) return false;
    ++in_use_;
    return true;
  }
  bool TryTake() {
    absl::MutexLock lock(&mu_);
    if (!Free()) return false;
    ++in_use_;
    return true;
  }
  void Give() {
    absl::MutexLock lock(&mu_);
    --in_use_;
  }

 private:
  bool Free() const ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) { return in_use_ < limit_; }

  absl::Mutex mu_;
  int limit_ ABSL_GUARDED_BY(mu_) = 1;
  int in_use_ ABSL_GUARDED_BY(mu_) = 0;
};

// Whether this thread holds a slot: a plan inside a plan (auto's member) plans in
// its caller's slot.
thread_local bool this_thread_plans = false;

Slots& TheSlots() {
  static Slots* const slots = new Slots;
  return *slots;
}

}  // namespace

void SetConcurrentPlans(int plans) { TheSlots().SetLimit(plans); }

int ConcurrentPlans() { return TheSlots().limit(); }

PlanSlot::~PlanSlot() {
  if (!held_) return;
  this_thread_plans = false;
  TheSlots().Give();
}

absl::Status PlanSlot::Acquire(
    std::optional<std::chrono::steady_clock::time_point> deadline,
    const std::function<bool()>& cancelled) {
  if (this_thread_plans) return absl::OkStatus();
  while (!held_) {
    if (cancelled && cancelled()) {
      return absl::CancelledError(
          "planning cancelled while it waited for a planner slot");
    }
    // A free slot is taken also past the deadline: the planner answers a late call
    // with its best plan so far; only a wait that outlasts the deadline fails.
    absl::Time until = absl::Now() + absl::Milliseconds(20);
    bool last_try = false;
    if (deadline.has_value()) {
      const auto left = *deadline - std::chrono::steady_clock::now();
      last_try = left <= std::chrono::steady_clock::duration::zero();
      until =
          last_try ? absl::Now() : std::min(until, absl::Now() + absl::FromChrono(left));
    }
    held_ = TheSlots().TakeBefore(until);
    if (!held_ && last_try) {
      return absl::DeadlineExceededError(
          "the deadline passed while the plan waited for a planner slot (all "
          "--planner_workers were planning other sessions)");
    }
  }
  this_thread_plans = true;
  return absl::OkStatus();
}

bool PlanSlot::TryAcquire() {
  if (this_thread_plans || held_) return false;
  held_ = TheSlots().TryTake();
  this_thread_plans = held_;
  return held_;
}

}  // namespace excite::plan
