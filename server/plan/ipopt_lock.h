#ifndef EXCITE_SERVER_PLAN_IPOPT_LOCK_H_
#define EXCITE_SERVER_PLAN_IPOPT_LOCK_H_

#include <chrono>
#include <cstdint>
#include <mutex>

namespace excite::plan {

// The one process-wide lock around Ipopt: MUMPS in Ipopt 3.11 is not
// thread-safe. SolveTnlp() holds it (through TimedIpoptLock) across an
// IpoptApplication's create, Initialize, OptimizeTNLP and destroy, so one solve
// runs at a time. Code that drives Ipopt itself must take it too.
std::mutex& IpoptMutex();

// Holds IpoptMutex() for its lifetime and adds the wait for it and the hold to
// the process's IpoptLockTotals. When the BLAS is not thread-safe
// (blas::BlasNeedsSerialising()) it holds blas::BlasMutex() too, since MUMPS
// calls the BLAS, except during the NLP's callbacks (IpoptCallbackUnlock): a
// Predict or a refit of another session then waits for one Ipopt iteration's
// linear algebra at most, not for a whole solve.
class TimedIpoptLock {
 public:
  TimedIpoptLock();
  ~TimedIpoptLock();
  TimedIpoptLock(const TimedIpoptLock&) = delete;
  TimedIpoptLock& operator=(const TimedIpoptLock&) = delete;

 private:
  std::chrono::steady_clock::time_point taken_;
};

// In an Ipopt callback: releases the BLAS lock a TimedIpoptLock of this thread
// holds, for its lifetime (the model's own BLAS calls take it call by call). A
// no-op when there is none (a thread-safe BLAS, or a callback called directly,
// as tests do). IpoptMutex() stays held.
class IpoptCallbackUnlock {
 public:
  IpoptCallbackUnlock();
  ~IpoptCallbackUnlock();
  IpoptCallbackUnlock(const IpoptCallbackUnlock&) = delete;
  IpoptCallbackUnlock& operator=(const IpoptCallbackUnlock&) = delete;

 private:
  bool released_ = false;
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
