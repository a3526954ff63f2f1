#include "server/plan/ipopt_lock.h"

#include <atomic>

#include "server/blas/blas_lock.h"

namespace excite::plan {
namespace {

std::atomic<int64_t> acquisitions{0};
std::atomic<int64_t> wait_ns{0};
std::atomic<int64_t> held_ns{0};

// Whether this thread holds IpoptMutex() through a TimedIpoptLock now, and for how
// long that hold has released it to callbacks.
thread_local bool holds_lock = false;
thread_local int64_t released_ns_of_this_hold = 0;

int64_t NanosecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now() - start)
      .count();
}

}  // namespace

std::recursive_mutex& IpoptMutex() {
  static std::recursive_mutex* const own = new std::recursive_mutex;
  return blas::BlasNeedsSerialising() ? blas::BlasMutex() : *own;
}

TimedIpoptLock::TimedIpoptLock() {
  const auto asked = std::chrono::steady_clock::now();
  IpoptMutex().lock();
  taken_ = std::chrono::steady_clock::now();
  wait_ns.fetch_add(NanosecondsSince(asked), std::memory_order_relaxed);
  acquisitions.fetch_add(1, std::memory_order_relaxed);
  holds_lock = true;
  released_ns_of_this_hold = 0;
}

TimedIpoptLock::~TimedIpoptLock() {
  held_ns.fetch_add(NanosecondsSince(taken_) - released_ns_of_this_hold,
                    std::memory_order_relaxed);
  holds_lock = false;
  IpoptMutex().unlock();
}

IpoptCallbackUnlock::IpoptCallbackUnlock() {
  if (!holds_lock) return;
  released_ = true;
  holds_lock = false;
  released_at_ = std::chrono::steady_clock::now();
  IpoptMutex().unlock();
}

IpoptCallbackUnlock::~IpoptCallbackUnlock() {
  if (!released_) return;
  const auto asked = std::chrono::steady_clock::now();
  IpoptMutex().lock();
  wait_ns.fetch_add(NanosecondsSince(asked), std::memory_order_relaxed);
  released_ns_of_this_hold += NanosecondsSince(released_at_);
  holds_lock = true;
}

IpoptLockTotals ReadIpoptLockTotals() {
  IpoptLockTotals totals;
  totals.acquisitions = acquisitions.load(std::memory_order_relaxed);
  totals.wait_seconds =
      static_cast<double>(wait_ns.load(std::memory_order_relaxed)) * 1e-9;
  totals.held_seconds =
      static_cast<double>(held_ns.load(std::memory_order_relaxed)) * 1e-9;
  return totals;
}

}  // namespace excite::plan
