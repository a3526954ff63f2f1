#ifndef EXCITE_SERVER_PLAN_IPOPT_LOCK_H_
#define EXCITE_SERVER_PLAN_IPOPT_LOCK_H_

#include <chrono>
#include <cstdint>
#include <mutex>

namespace excite::plan {

// How Ipopt solves share the process. MUMPS, the only linear solver of Debian's
// Ipopt 3.11, is not thread-safe (coin-or/Ipopt#733), so Ipopt's own work
// (create, Initialize, the iterations' linear algebra, destroy) runs under one
// process-wide mutex, IpoptMutex(). A solve gives it up while its NLP calls back
// into the model (IpoptCallbackUnlock), which is about half of a plan's time:
// the model work of concurrent plans (plan_slots.h bounds them) runs in parallel,
// and they take turns only for Ipopt's own steps. This is what Ipopt 3.14 does
// inside (MUMPS under a mutex per call), done one level up: MUMPS instances take
// turns between calls, never inside one.

// The mutex around Ipopt's own work. Code that drives Ipopt itself must hold it.
std::mutex& IpoptMutex();

// One solve's hold on Ipopt, for its lifetime: IpoptMutex(), and
// blas::BlasMutex() too when the BLAS is not thread-safe
// (blas::BlasNeedsSerialising()), since MUMPS calls the BLAS. Adds the waits and
// the holds to the process's IpoptLockTotals.
class TimedIpoptLock {
 public:
  TimedIpoptLock();
  ~TimedIpoptLock();
  TimedIpoptLock(const TimedIpoptLock&) = delete;
  TimedIpoptLock& operator=(const TimedIpoptLock&) = delete;
};

// In an Ipopt callback: releases IpoptMutex() and the BLAS lock that this thread's
// TimedIpoptLock holds, for its lifetime (the model's own BLAS calls take the
// BLAS lock call by call), and takes them back at its end.
// A no-op when this thread holds none (a callback called directly, as tests do).
class IpoptCallbackUnlock {
 public:
  IpoptCallbackUnlock();
  ~IpoptCallbackUnlock();
  IpoptCallbackUnlock(const IpoptCallbackUnlock&) = delete;
  IpoptCallbackUnlock& operator=(const IpoptCallbackUnlock&) = delete;

 private:
  bool released_ = false;
};

// What TimedIpoptLocks spent since the process started: how many solves took
// them, how long solves waited for IpoptMutex() (at the start and after each
// callback) and how long it was held, callbacks excluded.
// The held time per second of wall time is the share of one core that Ipopt's
// own work is serialised on.
struct IpoptLockTotals {
  int64_t acquisitions = 0;
  double wait_seconds = 0;
  double held_seconds = 0;
};
// Thread-safe; the three values are read one after the other, not as one snapshot.
IpoptLockTotals ReadIpoptLockTotals();

}  // namespace excite::plan

#endif  // EXCITE_SERVER_PLAN_IPOPT_LOCK_H_
