#ifndef EXCITE_SERVER_GP_DENSE_LINEAR_ALGEBRA_H_
#define EXCITE_SERVER_GP_DENSE_LINEAR_ALGEBRA_H_

#include <Eigen/Dense>

namespace excite::gp {

// The O(n^3) and O(n^2 m) kernels of the exact GP, on the system's LAPACK and
// BLAS: OpenBLAS's serial build where scripts/setup.sh or the image installed it.
// OpenBLAS picks AVX2/FMA or AVX-512 code for the CPU at run time (excite-server
// makes sure of it where OpenBLAS does not know the CPU: blas/cpu_kernels.h), so a
// portable binary gets them; Eigen's own kernels only use the instructions the build
// targets (SSE2 for a portable x86-64 build), 3-4x slower here at n >= 500
// (bench/gp). Each call runs on the calling thread, on a copy of LAPACK no other
// thread is in (blas::LapackTurn: calls from several threads run in parallel),
// except the small triangular solves below, which need none.
//
// Matrices may be blocks of larger ones (the leading dimension is the outer
// stride), column-major, as Eigen stores them.

// Cholesky factorisation A = L L^T in place (dpotrf): reads the lower triangle of
// the square `a`, leaves L there; the strict upper triangle is not touched. False
// if A is not (numerically) positive definite; `a` is then partly overwritten.
bool CholeskyInPlace(Eigen::Ref<Eigen::MatrixXd> a);

// A^-1 (full, symmetric) from the lower Cholesky factor L of A (dpotri):
// 2 n^3 / 3 flops, a third of solving against the identity.
Eigen::MatrixXd InverseFromCholesky(const Eigen::Ref<const Eigen::MatrixXd>& l);

// B <- L^-1 B and B <- L^-T B for the lower triangle L of the square `l`
// (dtrsm), B with l.rows() rows. A B of at most 64 columns (the points of a plan's
// model callback) is solved by Eigen's own kernel, with no copy to take, so that
// the model work of plans of different sessions runs in parallel: 1.2-1.4x
// OpenBLAS's time per call at 15-64 columns against its SSE3 kernels, 1.5-2.5x
// against its AVX-512 ones (3x at one column), a plan at n = 1000 7 % slower
// alone, and two at once 2x as many per second (docs/parallel-planning.md).
void SolveLower(const Eigen::Ref<const Eigen::MatrixXd>& l,
                Eigen::Ref<Eigen::MatrixXd> b);
void SolveLowerTransposed(const Eigen::Ref<const Eigen::MatrixXd>& l,
                          Eigen::Ref<Eigen::MatrixXd> b);

}  // namespace excite::gp

#endif  // EXCITE_SERVER_GP_DENSE_LINEAR_ALGEBRA_H_
