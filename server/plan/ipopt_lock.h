#ifndef EXCITE_SERVER_PLAN_IPOPT_LOCK_H_
#define EXCITE_SERVER_PLAN_IPOPT_LOCK_H_

#include <chrono>
#include <cstdint>
#include <mutex>

namespace excite::plan {

// The one process-wide lock around Ipopt: MUMPS in Ipopt 3.11 is not
// thread-safe. When the BLAS is not thread-safe either (blas/blas_lock.h) it is
// blas::BlasMutex(), since MUMPS calls the BLAS. SolveTnlp() holds it (through
// TimedIpoptLock) across an IpoptApplication's create, Initialize, OptimizeTNLP
// and destroy, except while the NLP's callbacks evaluate the model
// (IpoptCallbackUnlock): that work, about half of a plan, runs in parallel
// across plans. Code that drives Ipopt itself must take it too.
std::recursive_mutex& IpoptMutex();

// Holds IpoptMutex() for its lifetime and adds the wait for it and the hold to
// the process's IpoptLockTotals.
class TimedIpoptLock {
 public:
  TimedIpoptLock();
  ~TimedIpoptLock();
  TimedIpoptLock(const TimedIpoptLock&) = delete;
  TimedIpoptLock& operator=(const TimedIpoptLock&) = delete;

 private:
  std::chrono::steady_clock::time_point taken_;
};

// In an Ipopt callback: releases IpoptMutex() for its lifetime if this thread
// holds it through a TimedIpoptLock, and takes it back after (the wait counts as
// a wait, the time released not as held). A no-op on a thread that does not hold
// it (a callback called directly, as tests do).
class IpoptCallbackUnlock {
 public:
  IpoptCallbackUnlock();
  ~IpoptCallbackUnlock();
  IpoptCallbackUnlock(const IpoptCallbackUnlock&) = delete;
  IpoptCallbackUnlock& operator=(const IpoptCallbackUnlock&) = delete;

 private:
  bool released_ = false;
  std::chrono::steady_clock::time_point released_at_;
};

// What TimedIpoptLocks spent on IpoptMutex() since the process started: how often
// they took it, how long they waited for it and how long they held it. The held
// time per second of wall time is the share of one core that planning is
// serialised on.
struct IpoptLockTotals {
  int64_t acquisitions = 0;
  double wait_seconds = 0;
  double held_seconds = 0;
};
// Thread-safe; the three values are read one after the other, not as one snapshot.
IpoptLockTotals ReadIpoptLockTotals();

}  // namespace excite::plan

#endif  // EXCITE_SERVER_PLAN_IPOPT_LOCK_H_
