#include "server/plan/ipopt_library_calls.h"

#include <dlfcn.h>

#include <array>
#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <utility>

#include "server/blas/blas_lock.h"
#include "server/plan/mumps_copies.h"

namespace excite::plan {
namespace {

// The library's own definition of `name`: the next one after the executable's.
template <typename Function>
Function Next(const char* name) {
  void* const found = dlsym(RTLD_NEXT, name);
  if (found == nullptr) {
    // Only reachable if libipopt called a routine no loaded library defines,
    // which the dynamic linker refuses at load time.
    std::fprintf(stderr, "excite: no library defines %s\n", name);
    std::abort();
  }
  return reinterpret_cast<Function>(found);
}

MumpsCopies& TheMumpsCopies() {
  // Eight: loaded only as concurrent solves need them (at most the planner's
  // slots); glibc allows 16 namespaces, and its static TLS ran out at the 12th
  // copy in a test program.
  constexpr int kMaxCopies = 8;
  static MumpsCopies* const copies =
      new MumpsCopies(Next<MumpsCopies::Entry>("dmumps_c"), &MumpsMutex(), kMaxCopies);
  return *copies;
}

}  // namespace

std::recursive_mutex& MumpsMutex() {
  static std::recursive_mutex* const mutex = new std::recursive_mutex;
  return *mutex;
}

MumpsLockTotals ReadMumpsLockTotals() {
  const MumpsCopies::Totals read = TheMumpsCopies().ReadTotals();
  MumpsLockTotals totals;
  totals.acquisitions = read.calls;
  totals.wait_seconds = read.wait_seconds;
  totals.held_seconds = read.held_seconds;
  totals.copies = read.copies;
  return totals;
}

}  // namespace excite::plan

// The wrappers. A Fortran routine takes every argument by address and one hidden
// length per character argument at the end, so each wrapper passes on exactly the
// registers and stack slots its caller filled. Wrapped are the level-2 and level-3
// BLAS and the LAPACK routines that libipopt and MUMPS import (nm -D): those draw
// on OpenBLAS's shared buffers. Their level-1 routines (ddot_, daxpy_, idamax_,
// ...) and LAPACK's scalar helpers (dlamch_, ilaenv_, dlarfg_) use none and run in
// parallel.
extern "C" {
using A = void*;        // an argument, by address
using L = std::size_t;  // a hidden character length

void dmumps_c(A mumps);
void dgemm_(A, A, A, A, A, A, A, A, A, A, A, A, A, L, L);
void dgemv_(A, A, A, A, A, A, A, A, A, A, A, L);
void dsymv_(A, A, A, A, A, A, A, A, A, A, L);
void dsyrk_(A, A, A, A, A, A, A, A, A, A, L, L);
void dtrsm_(A, A, A, A, A, A, A, A, A, A, A, L, L, L, L);
void dpotrf_(A, A, A, A, A, L);
void dpotrs_(A, A, A, A, A, A, A, A, L);
void dgetrf_(A, A, A, A, A, A);
void dgetrs_(A, A, A, A, A, A, A, A, A, L);
void dsyev_(A, A, A, A, A, A, A, A, A, L, L);
void dorgqr_(A, A, A, A, A, A, A, A, A);

// Not the BLAS lock: the process's own MUMPS takes it call by call in the BLAS
// wrappers below, and the other copies call their own BLAS.
void dmumps_c(A mumps) { excite::plan::TheMumpsCopies().Call(mumps); }

#define EXCITE_UNDER_BLAS_LOCK(name, ...)                              \
  static const auto real = excite::plan::Next<decltype(&name)>(#name); \
  const excite::blas::BlasLock lock;                                   \
  real(__VA_ARGS__)

void dgemm_(A a1, A a2, A a3, A a4, A a5, A a6, A a7, A a8, A a9, A a10, A a11, A a12,
            A a13, L l1, L l2) {
  EXCITE_UNDER_BLAS_LOCK(dgemm_, a1, a2, a3, a4, a5, a6, a7, a8, a9, a10, a11, a12, a13,
                         l1, l2);
}
void dgemv_(A a1, A a2, A a3, A a4, A a5, A a6, A a7, A a8, A a9, A a10, A a11, L l1) {
  EXCITE_UNDER_BLAS_LOCK(dgemv_, a1, a2, a3, a4, a5, a6, a7, a8, a9, a10, a11, l1);
}
void dsymv_(A a1, A a2, A a3, A a4, A a5, A a6, A a7, A a8, A a9, A a10, L l1) {
  EXCITE_UNDER_BLAS_LOCK(dsymv_, a1, a2, a3, a4, a5, a6, a7, a8, a9, a10, l1);
}
void dsyrk_(A a1, A a2, A a3, A a4, A a5, A a6, A a7, A a8, A a9, A a10, L l1, L l2) {
  EXCITE_UNDER_BLAS_LOCK(dsyrk_, a1, a2, a3, a4, a5, a6, a7, a8, a9, a10, l1, l2);
}
void dtrsm_(A a1, A a2, A a3, A a4, A a5, A a6, A a7, A a8, A a9, A a10, A a11, L l1,
            L l2, L l3, L l4) {
  EXCITE_UNDER_BLAS_LOCK(dtrsm_, a1, a2, a3, a4, a5, a6, a7, a8, a9, a10, a11, l1, l2, l3,
                         l4);
}
void dpotrf_(A a1, A a2, A a3, A a4, A a5, L l1) {
  EXCITE_UNDER_BLAS_LOCK(dpotrf_, a1, a2, a3, a4, a5, l1);
}
void dpotrs_(A a1, A a2, A a3, A a4, A a5, A a6, A a7, A a8, L l1) {
  EXCITE_UNDER_BLAS_LOCK(dpotrs_, a1, a2, a3, a4, a5, a6, a7, a8, l1);
}
void dgetrf_(A a1, A a2, A a3, A a4, A a5, A a6) {
  EXCITE_UNDER_BLAS_LOCK(dgetrf_, a1, a2, a3, a4, a5, a6);
}
void dgetrs_(A a1, A a2, A a3, A a4, A a5, A a6, A a7, A a8, A a9, L l1) {
  EXCITE_UNDER_BLAS_LOCK(dgetrs_, a1, a2, a3, a4, a5, a6, a7, a8, a9, l1);
}
void dsyev_(A a1, A a2, A a3, A a4, A a5, A a6, A a7, A a8, A a9, L l1, L l2) {
  EXCITE_UNDER_BLAS_LOCK(dsyev_, a1, a2, a3, a4, a5, a6, a7, a8, a9, l1, l2);
}

void dorgqr_(A a1, A a2, A a3, A a4, A a5, A a6, A a7, A a8, A a9) {
  EXCITE_UNDER_BLAS_LOCK(dorgqr_, a1, a2, a3, a4, a5, a6, a7, a8, a9);
}

#undef EXCITE_UNDER_BLAS_LOCK
}  // extern "C"

namespace excite::plan {

bool IpoptLibraryCallsAreWrapped() {
  // The process's first definition of each name (the one libipopt's PLT binds to)
  // must be this file's.
  static const bool wrapped = [] {
    const std::array<std::pair<const char*, void*>, 12> ours = {{
        {"dmumps_c", reinterpret_cast<void*>(&dmumps_c)},
        {"dgemm_", reinterpret_cast<void*>(&dgemm_)},
        {"dgemv_", reinterpret_cast<void*>(&dgemv_)},
        {"dsymv_", reinterpret_cast<void*>(&dsymv_)},
        {"dsyrk_", reinterpret_cast<void*>(&dsyrk_)},
        {"dtrsm_", reinterpret_cast<void*>(&dtrsm_)},
        {"dpotrf_", reinterpret_cast<void*>(&dpotrf_)},
        {"dpotrs_", reinterpret_cast<void*>(&dpotrs_)},
        {"dgetrf_", reinterpret_cast<void*>(&dgetrf_)},
        {"dgetrs_", reinterpret_cast<void*>(&dgetrs_)},
        {"dsyev_", reinterpret_cast<void*>(&dsyev_)},
        {"dorgqr_", reinterpret_cast<void*>(&dorgqr_)},
    }};
    for (const auto& [name, address] : ours) {
      if (dlsym(RTLD_DEFAULT, name) != address) return false;
    }
    return true;
  }();
  return wrapped;
}

}  // namespace excite::plan
