#ifndef EXCITE_SERVER_BLAS_BLAS_LOCK_H_
#define EXCITE_SERVER_BLAS_BLAS_LOCK_H_

#include <mutex>

#include "absl/status/status.h"

namespace excite::blas {

// Which BLAS the process loaded, and the one lock around it when it is not
// thread-safe. Debian's serial OpenBLAS is built without USE_LOCKING: two threads
// inside it at once share its buffer pool, and one gets wrong numbers (2 wrong
// Cholesky factors in 6,000 from two threads on this machine; 0 with BLIS or the
// reference BLAS). Ipopt's level-2/3 BLAS and LAPACK calls and those of the
// process's own copy of MUMPS take BlasLock (plan/ipopt_library_calls.h); the GP's
// run on copies of LAPACK instead (lapack_copies.h), under BlasLock only if no
// copy can be loaded.

// True when the BLAS loaded is an OpenBLAS (any build): its calls must not
// overlap. Decided once per process.
bool BlasNeedsSerialising();

// The process's BLAS lock (whatever BlasNeedsSerialising() says). Recursive: a
// LapackTurn on the process's own LAPACK holds it around a call that takes it
// again in that routine's wrapper (plan/ipopt_library_calls.cc), and so does a
// whole-solve fallback's callback.
std::recursive_mutex& BlasMutex();

// Holds BlasMutex() for its lifetime if BlasNeedsSerialising(); a no-op otherwise.
class BlasLock {
 public:
  BlasLock();
  BlasLock(const BlasLock&) = delete;
  BlasLock& operator=(const BlasLock&) = delete;

 private:
  std::unique_lock<std::recursive_mutex> lock_;
};

// OK unless the BLAS loaded is a threaded OpenBLAS, which excite does not run on
// (FAILED_PRECONDITION saying why and what to install). Servers call it at start.
absl::Status CheckBlasRunsOnTheCallingThread();

}  // namespace excite::blas

#endif  // EXCITE_SERVER_BLAS_BLAS_LOCK_H_
