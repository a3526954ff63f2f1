// SolveTnlp on a one-variable problem: it solves, and it accounts for the time
// spent waiting for and holding the process-wide Ipopt lock.

#include "server/plan/ipopt_solve.h"

#include <chrono>
#include <mutex>
#include <thread>

#include "gtest/gtest.h"
#include "server/blas/blas_lock.h"
#include "server/plan/ipopt_lock.h"

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

TEST(IpoptSolveTest, SolvesAndCountsTheTimeItHeldTheLock) {
  const IpoptLockTotals before = ReadIpoptLockTotals();
  Ipopt::SmartPtr<Parabola> nlp = new Parabola();
  const auto start = std::chrono::steady_clock::now();
  const IpoptOutcome outcome = SolveTnlp(nlp, IpoptSettings());
  const double wall = SecondsSince(start);
  const IpoptLockTotals after = ReadIpoptLockTotals();

  EXPECT_EQ(outcome.status, Ipopt::Solve_Succeeded);
  EXPECT_NEAR(nlp->solution, 3.0, 1e-6);
  EXPECT_EQ(after.acquisitions - before.acquisitions, 1);
  const double held = after.held_seconds - before.held_seconds;
  const double waited = after.wait_seconds - before.wait_seconds;
  EXPECT_GT(held, 0);
  // Both lie inside the call, one after the other.
  EXPECT_LE(held + waited, wall);
}

// A parabola whose objective callback, like the planner's, gives Ipopt's lock and
// the BLAS lock up while it runs: another thread can take both then.
class ParabolaWithOpenCallback : public Parabola {
 public:
  bool eval_f(Ipopt::Index n, const Ipopt::Number* x, bool new_x,
              Ipopt::Number& value) override {
    const IpoptCallbackUnlock unlocked;
    std::thread other([this] {
      if (blas::BlasMutex().try_lock()) {
        ++blas_taken_by_another_thread;
        blas::BlasMutex().unlock();
      }
      if (IpoptMutex().try_lock()) {
        ++ipopt_taken_by_another_thread;
        IpoptMutex().unlock();
      }
    });
    other.join();
    return Parabola::eval_f(n, x, new_x, value);
  }
  // The gradient callback does not give the lock up, as Ipopt's own work.
  bool eval_grad_f(Ipopt::Index n, const Ipopt::Number* x, bool new_x,
                   Ipopt::Number* g) override {
    std::thread other([this] {
      if (IpoptMutex().try_lock()) {
        ++ipopt_taken_outside_the_open_callback;
        IpoptMutex().unlock();
      }
    });
    other.join();
    return Parabola::eval_grad_f(n, x, new_x, g);
  }
  int blas_taken_by_another_thread = 0;
  int ipopt_taken_by_another_thread = 0;
  int ipopt_taken_outside_the_open_callback = 0;
};

TEST(IpoptSolveTest, CallbacksLetOtherThreadsUseIpoptAndTheBlas) {
  Ipopt::SmartPtr<ParabolaWithOpenCallback> nlp = new ParabolaWithOpenCallback();
  const IpoptOutcome outcome = SolveTnlp(nlp, IpoptSettings());
  EXPECT_EQ(outcome.status, Ipopt::Solve_Succeeded);
  EXPECT_NEAR(nlp->solution, 3.0, 1e-6);
  EXPECT_GT(nlp->blas_taken_by_another_thread, 0);
  EXPECT_GT(nlp->ipopt_taken_by_another_thread, 0);
  EXPECT_EQ(nlp->ipopt_taken_outside_the_open_callback, 0);
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
  const IpoptLockTotals before = ReadIpoptLockTotals();
  std::unique_lock<std::mutex> other(IpoptMutex());
  Ipopt::SmartPtr<Parabola> nlp = new Parabola();
  IpoptOutcome outcome;
  std::thread solver([&] { outcome = SolveTnlp(nlp, IpoptSettings()); });
  const auto held_from = std::chrono::steady_clock::now();
  std::this_thread::sleep_for(std::chrono::milliseconds(400));
  // The solver has asked for the lock by now at the latest...
  const double asked_by = SecondsSince(held_from);
  other.unlock();
  solver.join();
  const IpoptLockTotals after = ReadIpoptLockTotals();

  EXPECT_EQ(outcome.status, Ipopt::Solve_Succeeded);
  EXPECT_EQ(after.acquisitions - before.acquisitions, 1);
  // ...so it waited at most as long as the lock was held here, and at least as
  // long as it stayed held once the thread had asked (its start takes far less
  // than the 400 ms).
  const double waited = after.wait_seconds - before.wait_seconds;
  EXPECT_LE(waited, asked_by + 0.1);
  EXPECT_GE(waited, 0.2);
}

}  // namespace
}  // namespace excite::plan
