#ifndef EXCITE_SERVER_BLAS_LAPACK_COPIES_H_
#define EXCITE_SERVER_BLAS_LAPACK_COPIES_H_

#include <cstddef>
#include <mutex>

namespace excite::blas {

// The LAPACK routines the GP calls, by their Fortran interface: every argument by
// address, one hidden length per character argument at the end.
struct LapackRoutines {
  void (*dpotrf)(const char* uplo, const int* n, double* a, const int* lda, int* info,
                 std::size_t uplo_length);
  void (*dpotri)(const char* uplo, const int* n, double* a, const int* lda, int* info,
                 std::size_t uplo_length);
  void (*dtrtrs)(const char* uplo, const char* trans, const char* diag, const int* n,
                 const int* nrhs, const double* a, const int* lda, double* b,
                 const int* ldb, int* info, std::size_t uplo_length,
                 std::size_t trans_length, std::size_t diag_length);
};

// A LAPACK (with its BLAS) that no other thread is inside while this lives, so that
// the GP's factorisations of different outputs and sessions run in parallel on
// Debian's serial OpenBLAS, which is not thread-safe (blas_lock.h). On OpenBLAS the
// routines are a copy of the process's LAPACK and OpenBLAS loaded with dlmopen into
// a link namespace of its own (own buffers, own globals): a free loaded copy, or one
// more while fewer than 4 are loaded; when all are in use, the caller waits for
// one. The process's own BLAS stays Ipopt's and MUMPS's (plan/ipopt_library_calls.h),
// whose calls then never wait for a fit. If no copy can be loaded (glibc's static
// TLS or namespace limit; logged once), the process's own under the BLAS lock. On a
// thread-safe BLAS, the process's own routines, no lock.
class LapackTurn {
 public:
  LapackTurn();
  LapackTurn(const LapackTurn&) = delete;
  LapackTurn& operator=(const LapackTurn&) = delete;

  const LapackRoutines* operator->() const { return routines_; }

 private:
  const LapackRoutines* routines_ = nullptr;
  std::unique_lock<std::mutex> copy_;
  std::unique_lock<std::recursive_mutex> own_;
};

// Copies of LAPACK loaded so far by LapackTurn (0 on a thread-safe BLAS).
int LoadedLapackCopies();

}  // namespace excite::blas

#endif  // EXCITE_SERVER_BLAS_LAPACK_COPIES_H_
