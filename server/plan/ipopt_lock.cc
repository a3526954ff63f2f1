#include "server/plan/ipopt_lock.h"

#include <atomic>

#include "server/blas/blas_lock.h"

namespace excite::plan {
namespace {

using Clock = std::chrono::steady_clock;

std::atomic<int64_t> acquisitions{0};
std::atomic<int64_t> wait_ns{0};
std::atomic<int64_t> held_ns{0};

// What this thread's TimedIpoptLock holds now, and since when IpoptMutex().
thread_local bool holds_ipopt = false;
thread_local bool holds_blas = false;
thread_local Clock::time_point taken;

int64_t NanosecondsSince(Clock::time_point start) {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now() - start)
      .count();
}

// Takes IpoptMutex(), then the BLAS lock if the BLAS needs it (always in this
// order, so two solves cannot deadlock), counting the wait.
void TakeIpopt() {
  const auto asked = Clock::now();
  IpoptMutex().lock();
  if (blas::BlasNeedsSerialising()) {
    blas::BlasMutex().lock();
    holds_blas = true;
  }
  holds_ipopt = true;
  taken = Clock::now();
  wait_ns.fetch_add(NanosecondsSince(asked), std::memory_order_relaxed);
}

void GiveIpoptBack() {
  if (holds_blas) {
    holds_blas = false;
    blas::BlasMutex().unlock();
  }
  holds_ipopt = false;
  held_ns.fetch_add(NanosecondsSince(taken), std::memory_order_relaxed);
  IpoptMutex().unlock();
}

}  // namespace

std::mutex& IpoptMutex() {
  static std::mutex* const mutex = new std::mutex;
  return *mutex;
}

TimedIpoptLock::TimedIpoptLock() {
  acquisitions.fetch_add(1, std::memory_order_relaxed);
  TakeIpopt();
}

TimedIpoptLock::~TimedIpoptLock() {
  if (holds_ipopt) GiveIpoptBack();
}

IpoptCallbackUnlock::IpoptCallbackUnlock() {
  if (!holds_ipopt) return;
  released_ = true;
  GiveIpoptBack();
}

IpoptCallbackUnlock::~IpoptCallbackUnlock() {
  if (released_) TakeIpopt();
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
