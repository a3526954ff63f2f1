#include "server/gp/dense_linear_algebra.h"

#include <gtest/gtest.h>
#include <lapack.h>

#include <Eigen/Dense>
#include <atomic>
#include <chrono>
#include <future>
#include <thread>

#include "server/blas/blas_lock.h"
#include "server/blas/lapack_copies.h"

namespace excite::gp {
namespace {

// A symmetric positive definite n x n matrix with condition number ~1e3.
Eigen::MatrixXd Spd(int n, int seed) {
  std::srand(seed);
  const Eigen::MatrixXd a = Eigen::MatrixXd::Random(n, n);
  return a * a.transpose() / n + 1e-3 * Eigen::MatrixXd::Identity(n, n);
}

double RelativeError(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return (a - b).norm() / b.norm();
}

// Each kernel on a block of a larger matrix (leading dimension != n), against
// Eigen's own implementation, at sizes below and above OpenBLAS's blocking.
class DenseLinearAlgebraTest : public ::testing::TestWithParam<int> {};

TEST_P(DenseLinearAlgebraTest, CholeskyMatchesEigenAndLeavesTheRestAlone) {
  const int n = GetParam();
  const Eigen::MatrixXd a = Spd(n, 1);
  Eigen::MatrixXd storage = Eigen::MatrixXd::Constant(n + 7, n + 5, 42.0);
  storage.topLeftCorner(n, n) = a;
  ASSERT_TRUE(CholeskyInPlace(storage.topLeftCorner(n, n)));
  const Eigen::MatrixXd expected = a.llt().matrixL();
  const Eigen::MatrixXd got = storage.topLeftCorner(n, n).triangularView<Eigen::Lower>();
  EXPECT_LT(RelativeError(got, expected), 1e-12);
  // The strict upper triangle keeps A's entries; the rest of the storage is untouched.
  const Eigen::MatrixXd upper =
      storage.topLeftCorner(n, n).triangularView<Eigen::StrictlyUpper>();
  EXPECT_EQ(upper, Eigen::MatrixXd(a.triangularView<Eigen::StrictlyUpper>()));
  EXPECT_TRUE((storage.bottomRows(7).array() == 42.0).all());
  EXPECT_TRUE((storage.rightCols(5).array() == 42.0).all());
}

TEST_P(DenseLinearAlgebraTest, InverseFromCholeskyIsTheInverse) {
  const int n = GetParam();
  const Eigen::MatrixXd a = Spd(n, 2);
  Eigen::MatrixXd storage = Eigen::MatrixXd::Zero(n + 3, n + 3);
  storage.topLeftCorner(n, n) = a.llt().matrixL();
  const Eigen::MatrixXd inverse = InverseFromCholesky(storage.topLeftCorner(n, n));
  EXPECT_LT(RelativeError(inverse, a.inverse()), 1e-10);
  EXPECT_EQ(inverse, inverse.transpose());  // exactly symmetric
}

// Both paths: Eigen's solve (up to 64 right-hand sides) and LAPACK's (more).
TEST_P(DenseLinearAlgebraTest, TriangularSolvesMatchEigen) {
  const int n = GetParam();
  const Eigen::MatrixXd l = Spd(n, 3).llt().matrixL();
  std::srand(4);
  for (const int m : {9, 64, 65, 100}) {
    const Eigen::MatrixXd b = Eigen::MatrixXd::Random(n, m);
    Eigen::MatrixXd storage = Eigen::MatrixXd::Constant(n + 2, m + 3, 7.0);
    storage.topLeftCorner(n, m) = b;
    SolveLower(l, storage.topLeftCorner(n, m));
    EXPECT_LT(RelativeError(l * storage.topLeftCorner(n, m), b), 1e-12) << m;
    storage.topLeftCorner(n, m) = b;
    SolveLowerTransposed(l, storage.topLeftCorner(n, m));
    EXPECT_LT(RelativeError(l.transpose() * storage.topLeftCorner(n, m), b), 1e-12) << m;
    EXPECT_TRUE((storage.bottomRows(2).array() == 7.0).all());
    EXPECT_TRUE((storage.rightCols(3).array() == 7.0).all());
  }
}

INSTANTIATE_TEST_SUITE_P(Sizes, DenseLinearAlgebraTest, ::testing::Values(1, 5, 300));

TEST(DenseLinearAlgebraTest, CholeskyReportsAnIndefiniteMatrix) {
  Eigen::Matrix3d a;
  a << 1, 2, 0, 2, 1, 0, 0, 0, 1;  // eigenvalues 3, -1, 1
  Eigen::MatrixXd m = a;
  EXPECT_FALSE(CholeskyInPlace(m));
}

// Two threads factorising at once get what one gets alone. Debian's serial
// OpenBLAS, unlocked, got 2 of 6,000 such factors wrong on this machine: each
// factorisation runs on a copy of LAPACK no other thread is in
// (blas::LapackTurn).
TEST(DenseLinearAlgebraTest, ConcurrentFactorisationsAreExact) {
  const int n = 300;
  const Eigen::MatrixXd a = Eigen::MatrixXd::Random(n, n);
  const Eigen::MatrixXd k = a * a.transpose() + n * Eigen::MatrixXd::Identity(n, n);
  Eigen::MatrixXd alone = k;
  ASSERT_TRUE(CholeskyInPlace(alone));
  std::atomic<int> wrong{0};
  const auto factorise = [&] {
    for (int r = 0; r < 1000; ++r) {
      Eigen::MatrixXd l = k;
      if (!CholeskyInPlace(l) ||
          l.triangularView<Eigen::Lower>().toDenseMatrix() !=
              alone.triangularView<Eigen::Lower>().toDenseMatrix()) {
        ++wrong;
      }
    }
  };
  std::thread other(factorise);
  factorise();
  other.join();
  EXPECT_EQ(wrong.load(), 0);
}

// While one thread holds a copy of LAPACK, another gets a copy of its own at once,
// and both give the bits of the process's own LAPACK.
TEST(LapackTurnTest, TwoTurnsAtOnceRunOnCopiesOfTheirOwnWithTheSameBits) {
  if (!blas::BlasNeedsSerialising()) GTEST_SKIP() << "a thread-safe BLAS: no copies";
  const int n = 400;
  const Eigen::MatrixXd a = Eigen::MatrixXd::Random(n, n);
  const Eigen::MatrixXd k = a * a.transpose() + n * Eigen::MatrixXd::Identity(n, n);
  const char lower = 'L';
  const auto factor = [&](const blas::LapackRoutines* routines) {
    Eigen::MatrixXd l = k;
    int info = -1;
    routines->dpotrf(&lower, &n, l.data(), &n, &info, 1);
    EXPECT_EQ(info, 0);
    return Eigen::MatrixXd(l.triangularView<Eigen::Lower>());
  };
  Eigen::MatrixXd own = k;
  {
    const blas::BlasLock lock;
    lapack_int info = -1;
    LAPACK_dpotrf(&lower, &n, own.data(), &n, &info);
    ASSERT_EQ(info, 0);
  }
  own = own.triangularView<Eigen::Lower>();

  const blas::LapackTurn first;
  const blas::LapackRoutines* const first_routines = first.operator->();
  auto second = std::async(std::launch::async, [&] {
    const blas::LapackTurn turn;
    return std::make_pair(turn.operator->(), factor(turn.operator->()));
  });
  // It must not wait for `first`.
  ASSERT_EQ(second.wait_for(std::chrono::seconds(20)), std::future_status::ready);
  const auto [second_routines, second_factor] = second.get();
  EXPECT_NE(second_routines->dpotrf, first_routines->dpotrf);
  EXPECT_GE(blas::LoadedLapackCopies(), 2);
  EXPECT_EQ(factor(first_routines), own);
  EXPECT_EQ(second_factor, own);
}

TEST(DenseLinearAlgebraTest, EmptyMatricesAreFine) {
  Eigen::MatrixXd empty(0, 0);
  EXPECT_TRUE(CholeskyInPlace(empty));
  EXPECT_EQ(InverseFromCholesky(empty).size(), 0);
  Eigen::MatrixXd b(0, 3);
  SolveLower(empty, b);
  SolveLowerTransposed(empty, b);
}

}  // namespace
}  // namespace excite::gp
