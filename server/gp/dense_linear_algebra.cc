#include "server/gp/dense_linear_algebra.h"

#include <dlfcn.h>
#include <lapack.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cassert>

#include "absl/base/const_init.h"
#include "absl/status/status.h"
#include "absl/synchronization/mutex.h"

namespace excite::gp {
namespace {

// Debian's serial OpenBLAS gave an intermittently wrong factorisation when two
// threads (a model's outputs fitted in parallel) called it at once (1 run in ~25
// of DynamicsModelTest.IllConditionedDataGivesFinitePredictions): its calls are
// serialised until that is understood.
absl::Mutex blas_mutex(absl::kConstInit);

// LAPACK's Fortran interface takes every argument by pointer.
lapack_int Stride(const Eigen::Ref<const Eigen::MatrixXd>& m) {
  return static_cast<lapack_int>(std::max<Eigen::Index>(1, m.outerStride()));
}

void Solve(const Eigen::Ref<const Eigen::MatrixXd>& l, Eigen::Ref<Eigen::MatrixXd> b,
           char transpose) {
  assert(l.rows() == l.cols() && b.rows() == l.rows());
  if (b.rows() == 0 || b.cols() == 0) return;
  const lapack_int n = static_cast<lapack_int>(b.rows());
  const lapack_int nrhs = static_cast<lapack_int>(b.cols());
  const lapack_int lda = Stride(l);
  const lapack_int ldb = static_cast<lapack_int>(b.outerStride());
  const char lower = 'L', non_unit = 'N';
  lapack_int info = 0;
  // dtrtrs: dtrsm after a check for a zero pivot, which a factor with positive
  // pivots does not have.
  absl::MutexLock lock(&blas_mutex);
  LAPACK_dtrtrs(&lower, &transpose, &non_unit, &n, &nrhs, l.data(), &lda, b.data(), &ldb,
                &info);
  assert(info == 0);
}

}  // namespace

bool CholeskyInPlace(Eigen::Ref<Eigen::MatrixXd> a) {
  assert(a.rows() == a.cols());
  const lapack_int n = static_cast<lapack_int>(a.rows());
  if (n == 0) return true;
  const lapack_int lda = Stride(a);
  lapack_int info = 0;
  const char lower = 'L';
  {
    absl::MutexLock lock(&blas_mutex);
    LAPACK_dpotrf(&lower, &n, a.data(), &lda, &info);
  }
  return info == 0;
}

Eigen::MatrixXd InverseFromCholesky(const Eigen::Ref<const Eigen::MatrixXd>& l) {
  assert(l.rows() == l.cols());
  const lapack_int n = static_cast<lapack_int>(l.rows());
  Eigen::MatrixXd inverse(n, n);
  if (n == 0) return inverse;
  inverse.triangularView<Eigen::Lower>() = l.triangularView<Eigen::Lower>();
  lapack_int info = 0;
  const char lower = 'L';
  {
    absl::MutexLock lock(&blas_mutex);
    LAPACK_dpotri(&lower, &n, inverse.data(), &n, &info);
  }
  // info > 0 only for a zero diagonal entry, which a successful factorisation
  // (positive pivots) cannot leave.
  assert(info == 0);
  for (lapack_int j = 1; j < n; ++j) {
    inverse.col(j).head(j) = inverse.row(j).head(j).transpose();
  }
  return inverse;
}

void SolveLower(const Eigen::Ref<const Eigen::MatrixXd>& l,
                Eigen::Ref<Eigen::MatrixXd> b) {
  Solve(l, b, 'N');
}

void SolveLowerTransposed(const Eigen::Ref<const Eigen::MatrixXd>& l,
                          Eigen::Ref<Eigen::MatrixXd> b) {
  Solve(l, b, 'T');
}

absl::Status CheckBlasRunsOnTheCallingThread() {
  // OpenBLAS's threaded builds define openblas_get_parallel() != 0; other BLAS
  // libraries do not define it.
  using GetParallel = int (*)();
  const auto get_parallel =
      reinterpret_cast<GetParallel>(dlsym(RTLD_DEFAULT, "openblas_get_parallel"));
  if (get_parallel == nullptr || get_parallel() == 0) return absl::OkStatus();
  return absl::FailedPreconditionError(
      "the system's BLAS is a threaded OpenBLAS (libopenblas0-pthread or -openmp). It "
      "starts threads before main() that take SIGTERM, and its 60 KB of static TLS "
      "overflows the metrics server's thread stacks. Select the serial build: apt-get "
      "install libopenblas0-serial, then update-alternatives --set "
      "libblas.so.3-x86_64-linux-gnu "
      "/usr/lib/x86_64-linux-gnu/openblas-serial/libblas.so.3 and the same for "
      "liblapack.so.3 (scripts/setup.sh does both)");
}

}  // namespace excite::gp
