// SolveTnlp on a one-variable problem: it solves, on several threads at once, and
// its calls into MUMPS go through the wrapper that runs them on copies of MUMPS
// under their locks, which accounts for the time spent waiting for and holding
// them (the process's own copy's lock is MumpsMutex()).

#include "server/plan/ipopt_solve.h"

#include <chrono>
#include <mutex>
#include <thread>
#include <vector>

#include "gtest/gtest.h"
#include "server/plan/ipopt_library_calls.h"

namespace excite::plan {
namespace {

// min (x - 3)^2 over x in [-10, 10], from x = 0.
class Parabola : public Ipopt::TNLP {
 public:
  bool get_nlp_info(Ipopt::Index& n, Ipopt::Index& m, Ipopt::Index& nnz_jac_g,
                    Ipopt::Index& nnz_h_lag, IndexStyleEnum& index_style) override {
    n = 1;
    m = 0;
    nnz_jac_g = 0;
    nnz_h_lag = 0;
    index_style = C_STYLE;
    return true;
  }
  bool get_bounds_info(Ipopt::Index, Ipopt::Number* x_l, Ipopt::Number* x_u, Ipopt::Index,
                       Ipopt::Number*, Ipopt::Number*) override {
    x_l[0] = -10;
    x_u[0] = 10;
    return true;
  }
  bool get_starting_point(Ipopt::Index, bool, Ipopt::Number* x, bool, Ipopt::Number*,
                          Ipopt::Number*, Ipopt::Index, bool, Ipopt::Number*) override {
    x[0] = 0;
    return true;
  }
  bool eval_f(Ipopt::Index, const Ipopt::Number* x, bool, Ipopt::Number& f) override {
    f = (x[0] - 3) * (x[0] - 3);
    return true;
  }
  bool eval_grad_f(Ipopt::Index, const Ipopt::Number* x, bool,
                   Ipopt::Number* g) override {
    g[0] = 2 * (x[0] - 3);
    return true;
  }
  bool eval_g(Ipopt::Index, const Ipopt::Number*, bool, Ipopt::Index,
              Ipopt::Number*) override {
    return true;
  }
  bool eval_jac_g(Ipopt::Index, const Ipopt::Number*, bool, Ipopt::Index, Ipopt::Index,
                  Ipopt::Index*, Ipopt::Index*, Ipopt::Number*) override {
    return true;
  }
  void finalize_solution(Ipopt::SolverReturn, Ipopt::Index, const Ipopt::Number* x,
                         const Ipopt::Number*, const Ipopt::Number*, Ipopt::Index,
                         const Ipopt::Number*, const Ipopt::Number*, Ipopt::Number,
                         const Ipopt::IpoptData*,
                         Ipopt::IpoptCalculatedQuantities*) override {
    solution = x[0];
  }

  double solution = 0;
};

double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

TEST(IpoptSolveTest, SolvesAndCountsTheTimeItsMumpsCallsHeldTheLock) {
  ASSERT_TRUE(IpoptLibraryCallsAreWrapped());
  const MumpsLockTotals before = ReadMumpsLockTotals();
  Ipopt::SmartPtr<Parabola> nlp = new Parabola();
  const auto start = std::chrono::steady_clock::now();
  const IpoptOutcome outcome = SolveTnlp(nlp, IpoptSettings());
  const double wall = SecondsSince(start);
  const MumpsLockTotals after = ReadMumpsLockTotals();

  EXPECT_EQ(outcome.status, Ipopt::Solve_Succeeded);
  EXPECT_NEAR(nlp->solution, 3.0, 1e-6);
  // At least MUMPS's start, analysis, a factorisation, a solve and its end.
  EXPECT_GE(after.acquisitions - before.acquisitions, 5);
  const double held = after.held_seconds - before.held_seconds;
  const double waited = after.wait_seconds - before.wait_seconds;
  EXPECT_GT(held, 0);
  // Both lie inside the call, one after the other.
  EXPECT_LE(held + waited, wall);
}

// A parabola with its minimum at `target`.
class MovedParabola : public Parabola {
 public:
  explicit MovedParabola(double target) : target_(target) {}
  bool eval_f(Ipopt::Index, const Ipopt::Number* x, bool, Ipopt::Number& f) override {
    f = (x[0] - target_) * (x[0] - target_);
    return true;
  }
  bool eval_grad_f(Ipopt::Index, const Ipopt::Number* x, bool,
                   Ipopt::Number* g) override {
    g[0] = 2 * (x[0] - target_);
    return true;
  }

 private:
  double target_;
};

// Solves on four threads at once, Ipopt's own work in parallel and MUMPS's in
// turns: each finds its own minimum, with the same iterate as alone.
TEST(IpoptSolveTest, SolvesOnManyThreadsAtOnceAsAlone) {
  constexpr int kThreads = 4;
  constexpr int kSolvesPerThread = 40;
  std::vector<double> alone(kThreads);
  for (int t = 0; t < kThreads; ++t) {
    Ipopt::SmartPtr<MovedParabola> nlp = new MovedParabola(-4.0 + 2.5 * t);
    ASSERT_EQ(SolveTnlp(nlp, IpoptSettings()).status, Ipopt::Solve_Succeeded);
    alone[t] = nlp->solution;
  }
  std::vector<int> same(kThreads, 0);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      for (int k = 0; k < kSolvesPerThread; ++k) {
        Ipopt::SmartPtr<MovedParabola> nlp = new MovedParabola(-4.0 + 2.5 * t);
        const IpoptOutcome outcome = SolveTnlp(nlp, IpoptSettings());
        if (outcome.status == Ipopt::Solve_Succeeded && nlp->solution == alone[t]) {
          ++same[t];
        }
      }
    });
  }
  for (std::thread& thread : threads) thread.join();
  for (int t = 0; t < kThreads; ++t) {
    EXPECT_NEAR(alone[t], -4.0 + 2.5 * t, 1e-6);
    EXPECT_EQ(same[t], kSolvesPerThread) << "thread " << t;
  }
}

// A parabola whose objective takes 30 ms of wall time and no CPU time.
class SleepingParabola : public Parabola {
 public:
  bool eval_f(Ipopt::Index n, const Ipopt::Number* x, bool new_x,
              Ipopt::Number& value) override {
    std::this_thread::sleep_for(std::chrono::milliseconds(30));
    return Parabola::eval_f(n, x, new_x, value);
  }
};

// Ipopt's clock is ipopt_solve.cc's (a monotonic clock, no getrusage): its
// max_cpu_time then counts the sleeping callback, which getrusage would not.
TEST(IpoptSolveTest, IpoptTimesItselfWithTheMonotonicClock) {
  Ipopt::SmartPtr<SleepingParabola> nlp = new SleepingParabola();
  IpoptSettings settings;
  settings.numeric_options = {{"max_cpu_time", 0.02}};
  const IpoptOutcome outcome = SolveTnlp(nlp, settings);
  EXPECT_TRUE(outcome.options_accepted);
  EXPECT_EQ(outcome.status, Ipopt::Maximum_CpuTime_Exceeded);
}

TEST(IpoptSolveTest, CountsTheWaitWhileAnotherHoldsTheLock) {
  const MumpsLockTotals before = ReadMumpsLockTotals();
  std::unique_lock<std::recursive_mutex> other(MumpsMutex());
  Ipopt::SmartPtr<Parabola> nlp = new Parabola();
  IpoptOutcome outcome;
  std::thread solver([&] { outcome = SolveTnlp(nlp, IpoptSettings()); });
  const auto held_from = std::chrono::steady_clock::now();
  std::this_thread::sleep_for(std::chrono::milliseconds(400));
  // The solver has asked for the lock by now at the latest...
  const double asked_by = SecondsSince(held_from);
  other.unlock();
  solver.join();
  const MumpsLockTotals after = ReadMumpsLockTotals();

  EXPECT_EQ(outcome.status, Ipopt::Solve_Succeeded);
  EXPECT_GE(after.acquisitions - before.acquisitions, 5);
  // ...so it waited at most as long as the lock was held here, and at least as
  // long as it stayed held once the thread had asked (its start takes far less
  // than the 400 ms).
  const double waited = after.wait_seconds - before.wait_seconds;
  EXPECT_LE(waited, asked_by + 0.1);
  EXPECT_GE(waited, 0.2);
}

}  // namespace
}  // namespace excite::plan
