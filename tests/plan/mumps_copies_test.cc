// MumpsCopies on the real MUMPS, driven directly: an instance started while every
// loaded copy is in use gets a copy of its own, which factorises and solves while
// another copy's lock is held, with the same numbers as the process's own copy.

#include "server/plan/mumps_copies.h"

#include <dlfcn.h>
#include <dmumps_c.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "gtest/gtest.h"

namespace excite::plan {
namespace {

MumpsCopies::Entry LibraryDmumps() {
  // The next definition after the executable's wrapper: the library's own.
  return reinterpret_cast<MumpsCopies::Entry>(dlsym(RTLD_NEXT, "dmumps_c"));
}

// A symmetric tridiagonal system of size n (lower triangle, 1-based), started
// (job -1) through `copies`.
class Tridiagonal {
 public:
  Tridiagonal(MumpsCopies* copies, int n) : copies_(copies), n_(n) {
    for (int i = 0; i < n; ++i) {
      Add(i + 1, i + 1, 4.0 + 0.01 * i);
      if (i + 1 < n) Add(i + 2, i + 1, -1.0);
    }
    mumps_.job = -1;
    mumps_.par = 1;
    mumps_.sym = 2;
    mumps_.comm_fortran = -987654;  // MUMPS's "no MPI communicator"
    copies_->Call(&mumps_);
    mumps_.icntl[0] = mumps_.icntl[1] = mumps_.icntl[2] = -1;  // silent
    mumps_.icntl[3] = 0;
  }
  ~Tridiagonal() {
    mumps_.job = -2;
    copies_->Call(&mumps_);
  }
  int started() const { return mumps_.infog[0]; }

  // Analysis, factorisation and solve of A x = b, b_i = 1 + sin i.
  std::vector<double> Solve() {
    std::vector<double> x(n_);
    for (int i = 0; i < n_; ++i) x[i] = 1.0 + std::sin(i);
    mumps_.n = n_;
    mumps_.nnz = static_cast<int64_t>(a_.size());
    mumps_.irn = rows_.data();
    mumps_.jcn = columns_.data();
    mumps_.a = a_.data();
    mumps_.rhs = x.data();
    mumps_.job = 6;
    copies_->Call(&mumps_);
    EXPECT_EQ(mumps_.infog[0], 0);
    return x;
  }

 private:
  void Add(int row, int column, double value) {
    rows_.push_back(row);
    columns_.push_back(column);
    a_.push_back(value);
  }
  MumpsCopies* copies_;
  int n_;
  std::vector<MUMPS_INT> rows_, columns_;
  std::vector<double> a_;
  DMUMPS_STRUC_C mumps_{};
};

// max |A x - b| for Tridiagonal's system.
double Residual(const std::vector<double>& x) {
  const int n = static_cast<int>(x.size());
  double worst = 0;
  for (int i = 0; i < n; ++i) {
    double ax = (4.0 + 0.01 * i) * x[i];
    if (i > 0) ax -= x[i - 1];
    if (i + 1 < n) ax -= x[i + 1];
    worst = std::max(worst, std::abs(ax - (1.0 + std::sin(i))));
  }
  return worst;
}

TEST(MumpsCopiesTest, AnInstanceStartedWhileTheCopyIsInUseRunsOnACopyOfItsOwn) {
  ASSERT_NE(LibraryDmumps(), nullptr);
  std::recursive_mutex own_lock;
  MumpsCopies copies(LibraryDmumps(), &own_lock, 4);
  Tridiagonal first(&copies, 300);
  ASSERT_EQ(first.started(), 0);
  EXPECT_EQ(copies.ReadTotals().copies, 1);

  std::vector<double> second_x;
  {
    Tridiagonal second(&copies, 300);  // the own copy is in use: a new one
    ASSERT_EQ(second.started(), 0);
    EXPECT_EQ(copies.ReadTotals().copies, 2);
    // With the own copy's lock held elsewhere, the second still solves: its
    // instance lives on the other copy.
    std::unique_lock<std::recursive_mutex> held(own_lock);
    std::thread other([&] { second_x = second.Solve(); });
    other.join();
  }
  const std::vector<double> first_x = first.Solve();
  EXPECT_LT(Residual(first_x), 1e-12);
  // The same library on the same numbers: the same bits.
  EXPECT_EQ(second_x, first_x);

  // Ended instances free their copies: no further copy is loaded.
  Tridiagonal third(&copies, 300);
  EXPECT_EQ(third.Solve(), first_x);
  EXPECT_EQ(copies.ReadTotals().copies, 2);
}

TEST(MumpsCopiesTest, SolvesOnManyThreadsAtOnceGiveTheSameBitsAsAlone) {
  std::recursive_mutex own_lock;
  MumpsCopies copies(LibraryDmumps(), &own_lock, 3);
  const std::vector<double> alone = Tridiagonal(&copies, 500).Solve();
  constexpr int kThreads = 4;  // more than the copies: some share
  std::vector<int> same(kThreads, 0);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      for (int k = 0; k < 50; ++k) {
        Tridiagonal system(&copies, 500);
        if (system.Solve() == alone) ++same[t];
      }
    });
  }
  for (std::thread& thread : threads) thread.join();
  for (int t = 0; t < kThreads; ++t) EXPECT_EQ(same[t], 50) << "thread " << t;
  const MumpsCopies::Totals totals = copies.ReadTotals();
  EXPECT_GE(totals.copies, 2);
  EXPECT_LE(totals.copies, 3);
  EXPECT_EQ(totals.calls, 3 * (1 + kThreads * 50));  // start, solve, end each
}

// Eight instances at once on a cap of eight: each solves right, whether every copy
// loaded or glibc's namespaces or static TLS ran out first (then the rest share).
TEST(MumpsCopiesTest, InstancesBeyondTheCopiesThatLoadShareThem) {
  std::recursive_mutex own_lock;
  MumpsCopies copies(LibraryDmumps(), &own_lock, 8);
  std::vector<std::unique_ptr<Tridiagonal>> systems;
  for (int k = 0; k < 8; ++k) {
    systems.push_back(std::make_unique<Tridiagonal>(&copies, 200));
    ASSERT_EQ(systems.back()->started(), 0) << k;
  }
  const int loaded = copies.ReadTotals().copies;
  EXPECT_GE(loaded, 2);
  EXPECT_LE(loaded, 8);
  const std::vector<double> first = systems[0]->Solve();
  EXPECT_LT(Residual(first), 1e-12);
  for (int k = 1; k < 8; ++k) EXPECT_EQ(systems[k]->Solve(), first) << k;
  std::printf("copies of MUMPS loaded for 8 instances: %d\n", loaded);
}

TEST(MumpsCopiesTest, WithOneCopyAllowedInstancesShareTheProcesssOwn) {
  std::recursive_mutex own_lock;
  MumpsCopies copies(LibraryDmumps(), &own_lock, 1);
  Tridiagonal first(&copies, 50);
  Tridiagonal second(&copies, 50);
  EXPECT_EQ(second.Solve(), first.Solve());
  EXPECT_EQ(copies.ReadTotals().copies, 1);
}

}  // namespace
}  // namespace excite::plan
