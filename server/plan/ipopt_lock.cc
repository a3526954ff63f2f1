#include "server/plan/ipopt_lock.h"

#include <atomic>

#include "server/blas/blas_lock.h"

namespace excite::plan {
namespace {

std::atomic<int64_t> acquisitions{0};
std::atomic<int64_t> wait_ns{0};
std::atomic<int64_t> held_ns{0};

// Whether a TimedIpoptLock of this thread holds blas::BlasMutex() now.
thread_local bool holds_blas = false;

int64_t NanosecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now() - start)
      .count();
}

}  // namespace

std::mutex& IpoptMutex() {
  static std::mutex* const mutex = new std::mutex;
  return *mutex;
}

TimedIpoptLock::TimedIpoptLock() {
  const auto asked = std::chrono::steady_clock::now();
  IpoptMutex().lock();
  taken_ = std::chrono::steady_clock::now();
  wait_ns.fetch_add(NanosecondsSince(asked), std::memory_order_relaxed);
  acquisitions.fetch_add(1, std::memory_order_relaxed);
  if (blas::BlasNeedsSerialising()) {
    blas::BlasMutex().lock();
    holds_blas = true;
  }
}

TimedIpoptLock::~TimedIpoptLock() {
  if (holds_blas) {
    holds_blas = false;
    blas::BlasMutex().unlock();
  }
  held_ns.fetch_add(NanosecondsSince(taken_), std::memory_order_relaxed);
  IpoptMutex().unlock();
}

IpoptCallbackUnlock::IpoptCallbackUnlock() {
  if (!holds_blas) return;
  released_ = true;
  holds_blas = false;
  blas::BlasMutex().unlock();
}

IpoptCallbackUnlock::~IpoptCallbackUnlock() {
  if (!released_) return;
  blas::BlasMutex().lock();
  holds_blas = true;
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
