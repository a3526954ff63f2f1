#include "server/plan/plan_slots.h"

#include <algorithm>
#include <cstdint>
#include <deque>

#include "absl/base/thread_annotations.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"

namespace excite::plan {
namespace {

// A counting semaphore (C++17 has none) that serves waiters in arrival order:
// absl::Mutex wakes any waiter, and without a queue a plan could wait through many
// others' (PlanInputs p99 was 5 x its p50 with 8 sessions on 2 slots).
class Slots {
 public:
  using Ticket = uint64_t;

  void SetLimit(int limit) {
    absl::MutexLock lock(&mu_);
    limit_ = std::max(1, limit);
  }
  int limit() {
    absl::MutexLock lock(&mu_);
    return limit_;
  }
  // A place at the end of the queue of waiters.
  Ticket Join() {
    absl::MutexLock lock(&mu_);
    queue_.push_back(next_ticket_);
    return next_ticket_++;
  }
  // True with a slot taken once `ticket` is first in the queue and a slot is free
  // (the ticket then leaves the queue); false if `until` came first (it stays).
  bool TakeBefore(Ticket ticket, absl::Time until) {
    absl::MutexLock lock(&mu_);
    const Turn turn{this, ticket};
    if (!mu_.AwaitWithDeadline(absl::Condition(&turn, &Turn::Ready), until)) {
      return false;
    }
    queue_.pop_front();
    ++in_use_;
    return true;
  }
  // A waiter that gives up leaves the queue.
  void Leave(Ticket ticket) {
    absl::MutexLock lock(&mu_);
    queue_.erase(std::find(queue_.begin(), queue_.end(), ticket));
  }
  // A free slot, if no one waits for one.
  bool TryTake() {
    absl::MutexLock lock(&mu_);
    if (in_use_ >= limit_ || !queue_.empty()) return false;
    ++in_use_;
    return true;
  }
  void Give() {
    absl::MutexLock lock(&mu_);
    --in_use_;
  }

 private:
  struct Turn {
    const Slots* slots;
    Ticket ticket;
    // Called by the mutex with it held.
    bool Ready() const ABSL_NO_THREAD_SAFETY_ANALYSIS {
      return slots->in_use_ < slots->limit_ && slots->queue_.front() == ticket;
    }
  };

  absl::Mutex mu_;
  int limit_ ABSL_GUARDED_BY(mu_) = 1;
  int in_use_ ABSL_GUARDED_BY(mu_) = 0;
  std::deque<Ticket> queue_ ABSL_GUARDED_BY(mu_);
  Ticket next_ticket_ ABSL_GUARDED_BY(mu_) = 0;
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
  Slots& slots = TheSlots();
  const Slots::Ticket ticket = slots.Join();
  while (!held_) {
    if (cancelled && cancelled()) {
      slots.Leave(ticket);
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
    held_ = slots.TakeBefore(ticket, until);
    if (!held_ && last_try) {
      slots.Leave(ticket);
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
