#ifndef EXCITE_SERVER_PLAN_IPOPT_LIBRARY_CALLS_H_
#define EXCITE_SERVER_PLAN_IPOPT_LIBRARY_CALLS_H_

#include <cstdint>
#include <mutex>

namespace excite::plan {

// How Ipopt solves share the process. Ipopt 3.11 is thread-safe as long as no
// Ipopt object is shared between threads and its linear solver is thread-safe
// (Ipopt's ChangeLog, 3.11.0, #167); MUMPS, the only linear solver of Debian's
// Ipopt, is not (coin-or/Ipopt#733), nor is Debian's serial OpenBLAS
// (blas/blas_lock.h). So solves run in parallel, each MUMPS instance on a copy of
// MUMPS of its own where one is free, and calls into the BLAS take turns, call by
// call: ipopt_library_calls.cc defines dmumps_c and the BLAS and LAPACK routines
// that libipopt and MUMPS call and that use OpenBLAS's shared buffers. The libraries
// call them through their PLT, so the executable's definitions win over the
// libraries' own; each takes its lock (the BLAS lock, or the lock of the copy of
// MUMPS the call's instance runs on: plan/mumps_copies.h) and calls the library's
// routine.

// The lock around every call into the process's own copy of MUMPS. Recursive:
// SolveTnlp's fallback below holds it around a whole solve.
std::recursive_mutex& MumpsMutex();

// True when this process's libipopt calls the wrappers above (their object is
// linked into the executable and exported to the libraries, as in every excite
// binary). When false, SolveTnlp holds MumpsMutex() and the BLAS lock around the
// whole solve, callbacks included: serial, but never unsafe.
bool IpoptLibraryCallsAreWrapped();

// What MUMPS calls spent on their copies' locks since the process started: how
// many calls, how long they waited for a lock and how long they held it, summed
// over the copies, and how many copies are loaded. Held time per second of wall
// time over copies is how many cores the process's solves spend in MUMPS; wait
// time is what sharing a copy cost.
struct MumpsLockTotals {
  int64_t acquisitions = 0;
  double wait_seconds = 0;
  double held_seconds = 0;
  int copies = 0;
};
// Thread-safe; the three values are read one after the other, not as one snapshot.
MumpsLockTotals ReadMumpsLockTotals();

}  // namespace excite::plan

#endif  // EXCITE_SERVER_PLAN_IPOPT_LIBRARY_CALLS_H_
