// Microbenchmarks of the GP engine: one ML-II objective evaluation (refactorise +
// LML gradient), a Cholesky row append, a batched prediction with Jacobians (15
// points, a planner horizon), and DynamicsModel::Refit for a pendulum and for a
// six-output system at n = 500 (the fit's outputs on 1 or 2 threads).

#include <benchmark/benchmark.h>

#include <Eigen/Dense>
#include <cmath>
#include <random>

#include "server/blas/cpu_kernels.h"
#include "server/gp/dynamics_model.h"
#include "server/gp/gp_model.h"
#include "server/gp/hyperparameters.h"

namespace excite::gp {
namespace {

struct Data {
  Eigen::MatrixXd x;
  Eigen::VectorXd y;
};

Data MakeData(int n, int d, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::normal_distribution<double> e(0.0, 0.1);
  Data data{Eigen::MatrixXd(n, d), Eigen::VectorXd(n)};
  for (int i = 0; i < n; ++i) {
    for (int l = 0; l < d; ++l) data.x(i, l) = u(rng);
    data.y(i) = std::sin(3.0 * data.x(i, 0)) + data.x.row(i).sum() / d + e(rng);
  }
  return data;
}

Hyperparameters MakeHyperparameters(int d) {
  Hyperparameters h;
  h.signal_variance = 1.0;
  h.lengthscales = Eigen::VectorXd::Constant(d, 0.8);
  h.noise_variance = 1e-2;
  return h;
}

void GpArgs(benchmark::internal::Benchmark* b) {
  for (int n : {250, 1000, 2000}) {
    for (int d : {3, 24}) b->Args({n, d});
  }
  b->ArgNames({"n", "z_dim"})->Unit(benchmark::kMillisecond);
}

// One evaluation of the ML-II objective: O(n^3) refactorisation + gradient.
void BM_LmlAndGradient(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const int d = static_cast<int>(state.range(1));
  const Data data = MakeData(n, d, 1);
  Hyperparameters h = MakeHyperparameters(d);
  GpModel gp;
  if (!gp.Reset(data.x, data.y, h).ok()) state.SkipWithError("reset failed");
  int k = 0;
  for (auto _ : state) {
    h.lengthscales(0) = 0.8 + 1e-3 * (++k % 2);
    if (!gp.SetHyperparameters(h).ok()) state.SkipWithError("factorisation failed");
    benchmark::DoNotOptimize(gp.log_marginal_likelihood());
    benchmark::DoNotOptimize(gp.LogMarginalLikelihoodGradient());
  }
}
BENCHMARK(BM_LmlAndGradient)->Apply(GpArgs);

// Row append of one sample (the model grows by one per iteration from n).
void BM_AddSample(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const int d = static_cast<int>(state.range(1));
  const Data data = MakeData(n, d, 2);
  const Data extra = MakeData(4096, d, 3);
  GpModel gp;
  if (!gp.Reset(data.x, data.y, MakeHyperparameters(d)).ok())
    state.SkipWithError("reset");
  int i = 0;
  for (auto _ : state) {
    const int r = i++ % 4096;
    if (!gp.AddSample(extra.x.row(r).transpose(), extra.y(r)).ok()) {
      state.SkipWithError("append failed");
    }
  }
  state.counters["final_n"] = gp.size();
}
BENCHMARK(BM_AddSample)->Apply(GpArgs);

// 15 points with mean, variance and both Jacobians.
void BM_Predict15WithJacobians(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const int d = static_cast<int>(state.range(1));
  const Data data = MakeData(n, d, 4);
  const Data query = MakeData(15, d, 5);
  GpModel gp;
  if (!gp.Reset(data.x, data.y, MakeHyperparameters(d)).ok())
    state.SkipWithError("reset");
  Eigen::VectorXd mean, var;
  Eigen::MatrixXd dmean, dvar;
  for (auto _ : state) {
    gp.Predict(query.x, &mean, &var, &dmean, &dvar);
    benchmark::DoNotOptimize(mean.data());
    benchmark::DoNotOptimize(dvar.data());
  }
}
BENCHMARK(BM_Predict15WithJacobians)->Apply(GpArgs);

// Pendulum transitions (state 2, input 1), measurement noise variance 0.05.
struct Transitions {
  Eigen::MatrixXd x, u, next;
};

Transitions Pendulum(int n, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> a(-3.0, 3.0), r(-6.0, 6.0), t(-2.0, 2.0);
  std::normal_distribution<double> e(0.0, std::sqrt(0.05));
  Transitions d{Eigen::MatrixXd(n, 2), Eigen::MatrixXd(n, 1), Eigen::MatrixXd(n, 2)};
  for (int i = 0; i < n; ++i) {
    const double th = a(rng), om = r(rng), u = t(rng), dt = 0.05;
    d.x.row(i) << th + e(rng), om + e(rng);
    d.u(i, 0) = u;
    d.next.row(i) << th + dt * om + e(rng),
        om + dt * (-9.81 * std::sin(th) - 0.1 * om + u) + e(rng);
  }
  return d;
}

DynamicsModelOptions PendulumOptions(int threads) {
  DynamicsModelOptions o;
  o.state_dim = 2;
  o.input_dim = 1;
  o.measurement_noise_variance = 0.05;
  o.input_center = Eigen::Vector3d::Zero();
  o.input_half_width = Eigen::Vector3d(3.0, 6.0, 2.0);
  o.fit_threads = threads;
  return o;
}

// The receding-horizon step: add one sample, Refit (warm start). A fixed 20
// iterations, so n runs from 300 to 319.
void BM_RefitWarmPendulum(benchmark::State& state) {
  const int n = 300;
  const Transitions d = Pendulum(n + 1000, 6);
  auto model = DynamicsModel::Create(PendulumOptions(static_cast<int>(state.range(0))));
  if (!model.ok() ||
      !model->AddSamples(d.x.topRows(n - 1), d.u.topRows(n - 1), d.next.topRows(n - 1))
           .ok() ||
      !model->Refit().ok()) {
    state.SkipWithError("setup failed");
    return;
  }
  int i = n - 1;
  double evaluations = 0, iterations = 0;
  for (auto _ : state) {
    (void)model->AddSamples(d.x.row(i), d.u.row(i), d.next.row(i));
    ++i;
    auto s = model->Refit();
    if (!s.ok()) state.SkipWithError("refit failed");
    evaluations += s->evaluations;
    iterations += s->iterations;
  }
  state.counters["evals"] =
      benchmark::Counter(evaluations, benchmark::Counter::kAvgIterations);
  state.counters["iters"] =
      benchmark::Counter(iterations, benchmark::Counter::kAvgIterations);
  state.counters["final_n"] = model->sample_count();
}
BENCHMARK(BM_RefitWarmPendulum)
    ->ArgName("threads")
    ->Arg(1)
    ->Arg(2)
    ->Iterations(20)
    ->Unit(benchmark::kMillisecond);

// First fit (no warm start: default + random restarts) at n = 300.
void BM_RefitColdPendulum(benchmark::State& state) {
  const Transitions d = Pendulum(300, 7);
  double evaluations = 0;
  for (auto _ : state) {
    auto model = DynamicsModel::Create(PendulumOptions(static_cast<int>(state.range(0))));
    (void)model->AddSamples(d.x, d.u, d.next);
    auto s = model->Refit();
    if (!s.ok()) state.SkipWithError("refit failed");
    evaluations += s->evaluations;
  }
  state.counters["evals"] =
      benchmark::Counter(evaluations, benchmark::Counter::kAvgIterations);
}
BENCHMARK(BM_RefitColdPendulum)
    ->ArgName("threads")
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond);

// A cold fit of six outputs at n = 500: a chain of three damped oscillators
// (state 6, input 3), data spread over the region as an exploration leaves it.
void BM_RefitColdSixOutputs(benchmark::State& state) {
  constexpr int n = 500;
  std::mt19937_64 rng(8);
  std::uniform_real_distribution<double> p(-2.0, 2.0), v(-4.0, 4.0), t(-1.0, 1.0);
  std::normal_distribution<double> e(0.0, 0.01);
  Eigen::MatrixXd x(n, 6), u(n, 3), next(n, 6);
  for (int i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) {
      const double q = p(rng), w = v(rng), f = t(rng), dt = 0.05;
      const double coupling = k > 0 ? 0.5 * (x(i, 2 * k - 2) - q) : 0.0;
      x(i, 2 * k) = q;
      x(i, 2 * k + 1) = w;
      u(i, k) = f;
      next(i, 2 * k) = q + dt * w + e(rng);
      next(i, 2 * k + 1) =
          w + dt * (-4.0 * std::sin(q) - 0.2 * w + coupling + f) + e(rng);
    }
  }
  DynamicsModelOptions o;
  o.state_dim = 6;
  o.input_dim = 3;
  o.measurement_noise_variance = 1e-4;
  o.input_center = Eigen::VectorXd::Zero(9);
  o.input_half_width = Eigen::VectorXd::Ones(9);
  o.input_half_width << 2, 4, 2, 4, 2, 4, 1, 1, 1;
  o.fit_threads = static_cast<int>(state.range(0));
  double evaluations = 0;
  for (auto _ : state) {
    auto model = DynamicsModel::Create(o);
    (void)model->AddSamples(x, u, next);
    auto s = model->Refit();
    if (!s.ok()) state.SkipWithError("refit failed");
    evaluations += s->evaluations;
  }
  state.counters["evals"] =
      benchmark::Counter(evaluations, benchmark::Counter::kAvgIterations);
}
BENCHMARK(BM_RefitColdSixOutputs)
    ->ArgName("threads")
    ->Arg(1)
    ->Arg(2)
    ->Iterations(2)
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace excite::gp

// The kernels the server runs with (server/blas/cpu_kernels.h).
int main(int argc, char** argv) {
  excite::blas::RunAgainWithTheCpusBlasKernels(argv);
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
