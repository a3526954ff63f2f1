#include "server/gp/dense_linear_algebra.h"

#include <lapack.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cassert>

#include "server/blas/lapack_copies.h"

namespace excite::gp {
namespace {

static_assert(sizeof(lapack_int) == sizeof(int), "blas::LapackRoutines takes int");

// LAPACK's Fortran interface takes every argument by pointer.
lapack_int Stride(const Eigen::Ref<const Eigen::MatrixXd>& m) {
  return static_cast<lapack_int>(std::max<Eigen::Index>(1, m.outerStride()));
}

// Up to this many right-hand sides, Eigen's solve (thread-safe, no lock): see the
// header.
constexpr Eigen::Index kEigenSolveColumns = 64;

void Solve(const Eigen::Ref<const Eigen::MatrixXd>& l, Eigen::Ref<Eigen::MatrixXd> b,
           char transpose) {
  assert(l.rows() == l.cols() && b.rows() == l.rows());
  if (b.rows() == 0 || b.cols() == 0) return;
  if (b.cols() <= kEigenSolveColumns) {
    if (transpose == 'N') {
      l.triangularView<Eigen::Lower>().solveInPlace(b);
    } else {
      l.triangularView<Eigen::Lower>().transpose().solveInPlace(b);
    }
    return;
  }
  const lapack_int n = static_cast<lapack_int>(b.rows());
  const lapack_int nrhs = static_cast<lapack_int>(b.cols());
  const lapack_int lda = Stride(l);
  const lapack_int ldb = static_cast<lapack_int>(b.outerStride());
  const char lower = 'L', non_unit = 'N';
  lapack_int info = 0;
  // dtrtrs: dtrsm after a check for a zero pivot, which a factor with positive
  // pivots does not have.
  const blas::LapackTurn lapack;
  lapack->dtrtrs(&lower, &transpose, &non_unit, &n, &nrhs, l.data(), &lda, b.data(), &ldb,
                 &info, 1, 1, 1);
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
    const blas::LapackTurn lapack;
    lapack->dpotrf(&lower, &n, a.data(), &lda, &info, 1);
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
    const blas::LapackTurn lapack;
    lapack->dpotri(&lower, &n, inverse.data(), &n, &info, 1);
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

}  // namespace excite::gp
