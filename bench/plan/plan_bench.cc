// One receding-horizon step of rec, mi and roi (DynamicsModel::Refit +
// Planner::PlanInputs), one `pa` and one `sep` plan on the pendulum with n = 300 samples
// and M = 15, the paper's setting (sim/configs/pendulum.textproto: m = l = 1, b = 0.1, dt
// = 0.1 s, |u| <= 3, measurement noise variance 0.05), and the rec loop from n = 100 to
// 2000 under a refit schedule. Counters split the time into refit and plan. And one
// half-cheetah rec plan at n = 500, M = 10 (MuJoCo plant, 18 GPs on z of dimension 24,
// sim/configs/half_cheetah.textproto).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <memory>
#include <random>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "server/gp/dynamics_model.h"
#include "server/gp/refit_schedule.h"
#include "server/plan/planner.h"
#include "server/plan/prbs_signal.h"
#include "server/service/config_validation.h"
#include "server/service/session_options.h"
#include "sim/plants/pendulum.h"
#include "sim/plants/plant_factory.h"
#include "sim/sim_config.h"

namespace excite::plan {
namespace {

using Clock = std::chrono::steady_clock;

double Ms(Clock::duration d) {
  return std::chrono::duration<double, std::milli>(d).count();
}

// Noisy transitions of the pendulum under random inputs held 5 steps (what an
// exploration that has run for a while looks like).
struct Transitions {
  Eigen::MatrixXd states, inputs, next;
};

Transitions PendulumData(int n, uint64_t seed = 11, double noise_variance = 0.05) {
  const sim::Pendulum pendulum(sim::PendulumParameters{}, 0.1, 10);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> input(-3.0, 3.0);
  std::normal_distribution<double> noise(0.0, std::sqrt(noise_variance));
  Transitions t{Eigen::MatrixXd(n, 2), Eigen::MatrixXd(n, 1), Eigen::MatrixXd(n, 2)};
  Eigen::VectorXd x = Eigen::Vector2d(0.0, 0.0);
  Eigen::VectorXd u(1);
  for (int k = 0; k < n; ++k) {
    if (k % 5 == 0) u(0) = input(rng);
    const Eigen::VectorXd x1 = pendulum.Step(x, u);
    t.states.row(k) = (x + Eigen::Vector2d(noise(rng), noise(rng))).transpose();
    t.inputs(k, 0) = u(0);
    t.next.row(k) = (x1 + Eigen::Vector2d(noise(rng), noise(rng))).transpose();
    x = x1;
  }
  return t;
}

// A model holding the first n transitions of `data`, fitted once; sparse above
// `sparse_above` samples (0: exact).
// A model of the options holding the first n transitions of `data`, fitted once
// (aborts if that fails: the benchmarks measure nothing without it).
gp::DynamicsModel FittedModel(const gp::DynamicsModelOptions& options,
                              const Transitions& data, int n) {
  auto model = gp::DynamicsModel::Create(options);
  if (!model.ok() ||
      !model
           ->AddSamples(data.states.topRows(n), data.inputs.topRows(n),
                        data.next.topRows(n))
           .ok() ||
      !model->Refit().ok()) {
    std::abort();
  }
  return *std::move(model);
}

gp::DynamicsModel FittedPendulumModel(const Transitions& data, int n,
                                      int sparse_above = 0) {
  gp::DynamicsModelOptions o;
  o.sparse_above = sparse_above;
  o.state_dim = 2;
  o.input_dim = 1;
  o.measurement_noise_variance = 0.05;
  o.input_center = Eigen::Vector3d(0.0, 0.0, 0.0);
  o.input_half_width = Eigen::Vector3d(M_PI, 8.0, 3.0);
  return FittedModel(o, data, n);
}

// The pendulum config's bounds; the region of interest is what sep and roi need.
PlanOptions PendulumOptions(Strategy strategy) {
  PlanOptions o;
  o.strategy = strategy;
  o.horizon = 15;
  o.input_lower = Eigen::VectorXd::Constant(1, -3.0);
  o.input_upper = Eigen::VectorXd::Constant(1, 3.0);
  o.state_lower = Eigen::Vector2d(-M_PI, -8.0);
  o.state_upper = Eigen::Vector2d(M_PI, 8.0);
  return o;
}

// BM_RecStep's third argument.
constexpr Strategy kStepStrategies[] = {Strategy::kRec, Strategy::kMi, Strategy::kRoi};

// The half-cheetah benchmark's configuration, sim/configs/half_cheetah.textproto,
// with the session's defaults filled as the server fills them (aborts if it cannot
// be read or is invalid: the benchmark measures nothing without it).
v1::SimConfig HalfCheetahConfig() {
  absl::StatusOr<v1::SimConfig> config = sim::LoadSimConfig(EXCITE_HALF_CHEETAH_CONFIG);
  if (!config.ok() || !service::ValidateSessionConfig(config->mutable_session()).ok()) {
    std::abort();
  }
  return *std::move(config);
}

// Transitions of the config's plant from its initial state under the server's PRBS
// within the config's input bounds (held 5 samples), as `excite-sim
// --strategy=prbs` collects them, with the config's measurement noise.
Transitions PrbsTransitions(const v1::SimConfig& config, int n, uint64_t seed = 1) {
  absl::StatusOr<std::unique_ptr<sim::Plant>> plant = sim::MakePlant(config.plant());
  if (!plant.ok()) std::abort();
  const v1::SessionConfig& session = config.session();
  const int dx = session.state_dim(), du = session.input_dim();
  Eigen::VectorXd lower(du), upper(du);
  for (int j = 0; j < du; ++j) {
    lower(j) = session.input_bounds(j).lower();
    upper(j) = session.input_bounds(j).upper();
  }
  const Eigen::MatrixXd inputs = PrbsSignal(lower, upper, 5, seed, 0, n);
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0.0, std::sqrt(session.noise().variance()));
  Transitions t{Eigen::MatrixXd(n, dx), Eigen::MatrixXd(n, du), Eigen::MatrixXd(n, dx)};
  Eigen::VectorXd x = Eigen::Map<const Eigen::VectorXd>(
      config.plant().initial_state().data(), config.plant().initial_state_size());
  const auto noisy = [&](const Eigen::VectorXd& v) {
    Eigen::VectorXd out = v;
    for (Eigen::Index i = 0; i < out.size(); ++i) out(i) += noise(rng);
    return out;
  };
  for (int k = 0; k < n; ++k) {
    const Eigen::VectorXd u = inputs.row(k).transpose();
    const Eigen::VectorXd x1 = (*plant)->Step(x, u);
    t.states.row(k) = noisy(x).transpose();
    t.inputs.row(k) = u.transpose();
    t.next.row(k) = noisy(x1).transpose();
    x = x1;
  }
  return t;
}

// One rec PlanInputs of the half-cheetah at n samples, M = 10 (Issue 13's target:
// <= 1 s), with the model and planner options the server derives from the config.
// The model's hyperparameters come from one cold fit on all n samples (about 20 s
// at n = 500 on 2 cores, not timed). Each iteration plans from the next measured
// state with the previous plan's warm start; the model does not change between
// plans.
void BM_HalfCheetahPlan(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const v1::SimConfig config = HalfCheetahConfig();
  const Transitions data = PrbsTransitions(config, n + 20);
  const gp::DynamicsModel model =
      FittedModel(service::ModelOptionsFromConfig(config.session()), data, n);
  Planner planner(service::PlanOptionsFromConfig(config.session()));
  std::vector<double> plan_ms;
  double iterations = 0.0, objective = 0.0;
  int k = n;
  for (auto _ : state) {
    const Clock::time_point t0 = Clock::now();
    PlanSummary summary;
    auto plan = planner.PlanInputs(model, data.next.row(k).transpose(), 0, PlanLimits{},
                                   &summary);
    plan_ms.push_back(Ms(Clock::now() - t0));
    k = std::min(k + 1, n + 19);
    if (!plan.ok()) {
      state.SkipWithError("plan failed");
      break;
    }
    iterations += summary.iterations;
    objective += summary.objective;
    benchmark::DoNotOptimize(plan->inputs.data());
  }
  if (plan_ms.empty()) return;
  std::sort(plan_ms.begin(), plan_ms.end());
  state.counters["plan_ms_p50"] = plan_ms[plan_ms.size() / 2];
  state.counters["plan_ms_max"] = plan_ms.back();
  const auto avg = benchmark::Counter::kAvgIterations;
  state.counters["ipopt_iters"] = benchmark::Counter(iterations, avg);
  state.counters["objective"] = benchmark::Counter(objective, avg);
}
// Args: samples.
BENCHMARK(BM_HalfCheetahPlan)
    ->Arg(500)
    ->Iterations(10)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// One receding-horizon step at n ~ 300: add the newest transition, refit
// (hyperparameters warm-started from the previous fit), plan from the newest
// measured state with the warm start of the previous plan. n grows by one per
// iteration (300 -> 300 + iterations).
void BM_RecStep(benchmark::State& state) {
  const int kMaxSteps = 50;
  const Transitions data = PendulumData(300 + kMaxSteps);
  gp::DynamicsModel model = FittedPendulumModel(data, 300);
  PlanOptions options = PendulumOptions(kStepStrategies[state.range(2)]);
  if (state.range(0) > 0) options.max_iterations = static_cast<int>(state.range(0));
  if (state.range(1) >= 0) options.restarts = static_cast<int>(state.range(1));
  Planner planner(options);
  double refit_ms = 0.0, plan_ms = 0.0, iterations = 0.0, entropy = 0.0;
  int k = 300;
  for (auto _ : state) {
    if (k >= 300 + kMaxSteps) {
      state.SkipWithError("too many iterations for the pregenerated data");
      break;
    }
    const Clock::time_point t0 = Clock::now();
    const absl::Status added =
        model.AddSamples(data.states.row(k), data.inputs.row(k), data.next.row(k));
    auto fit = model.Refit();
    const Clock::time_point t1 = Clock::now();
    PlanSummary summary;
    auto plan = planner.PlanInputs(model, data.next.row(k).transpose(), 0, PlanLimits{},
                                   &summary);
    const Clock::time_point t2 = Clock::now();
    ++k;
    if (!added.ok() || !fit.ok() || !plan.ok()) {
      state.SkipWithError("add, refit or plan failed");
      break;
    }
    refit_ms += Ms(t1 - t0);
    plan_ms += Ms(t2 - t1);
    iterations += summary.iterations;
    entropy += summary.objective;
    benchmark::DoNotOptimize(plan->inputs.data());
  }
  const auto avg = benchmark::Counter::kAvgIterations;
  state.counters["refit_ms"] = benchmark::Counter(refit_ms, avg);
  state.counters["plan_ms"] = benchmark::Counter(plan_ms, avg);
  state.counters["ipopt_iters"] = benchmark::Counter(iterations, avg);
  state.counters["objective"] = benchmark::Counter(entropy, avg);
}
// Args: (max_iterations, restarts, strategy); 0 / -1 = the PlanOptions defaults;
// strategy 0 rec, 1 mi, 2 roi (kStepStrategies).
BENCHMARK(BM_RecStep)
    ->Args({0, -1, 0})
    ->Args({0, 0, 0})
    ->Args({0, 3, 0})
    ->Args({0, -1, 1})
    ->Args({0, -1, 2})
    ->Iterations(10)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// The rec loop as a session runs it as n grows: add the newest transition, refit
// when the schedule says so (warm-started), plan. Args: (n at the start, refit
// growth in per mille: 0 refits at every sample, as the paper). Reports the median
// and the slowest step, and how many of the 40 steps refitted.
void BM_RecStepAtSize(benchmark::State& state) {
  const int n0 = static_cast<int>(state.range(0));
  gp::RefitSchedule schedule;
  schedule.growth = static_cast<double>(state.range(1)) / 1000.0;
  const int kSteps = 40;
  const Transitions data = PendulumData(n0 + kSteps);
  gp::DynamicsModel model =
      FittedPendulumModel(data, n0, static_cast<int>(state.range(2)));
  Planner planner(PendulumOptions(Strategy::kRec));
  std::vector<double> step_ms;
  int refits = 0;
  int k = n0;
  for (auto _ : state) {
    if (k >= n0 + kSteps) {
      state.SkipWithError("too many iterations for the pregenerated data");
      break;
    }
    const Clock::time_point t0 = Clock::now();
    absl::Status ok =
        model.AddSamples(data.states.row(k), data.inputs.row(k), data.next.row(k));
    if (ok.ok() &&
        gp::RefitDue(schedule, model.sample_count(), model.samples_since_fit())) {
      ok = model.Refit().status();
      ++refits;
    }
    PlanSummary summary;
    auto plan = ok.ok() ? planner.PlanInputs(model, data.next.row(k).transpose(), 0,
                                             PlanLimits{}, &summary)
                        : absl::StatusOr<Plan>(ok);
    step_ms.push_back(Ms(Clock::now() - t0));
    ++k;
    if (!plan.ok()) {
      state.SkipWithError("add, refit or plan failed");
      break;
    }
    benchmark::DoNotOptimize(plan->inputs.data());
  }
  if (step_ms.empty()) return;
  std::sort(step_ms.begin(), step_ms.end());
  state.counters["step_ms_p50"] = step_ms[step_ms.size() / 2];
  state.counters["step_ms_max"] = step_ms.back();
  state.counters["refits"] = refits;
  // One-step accuracy on another trajectory, noise-free: the sparse model's
  // price.
  const Transitions test = PendulumData(500, 12, 0.0);
  Eigen::MatrixXd z(500, 3), mean;
  z << test.states, test.inputs;
  model.Predict(z, &mean, nullptr, nullptr, nullptr);
  state.counters["rmse"] = std::sqrt((mean - test.next).squaredNorm() / 500);
  const std::vector<int> inducing = model.inducing_counts();
  state.counters["inducing"] = inducing.empty() ? 0 : inducing.front() + inducing.back();
  // One warm refit at the final size, outside the steps.
  const Clock::time_point t0 = Clock::now();
  if (!model.Refit().ok()) state.SkipWithError("refit failed");
  state.counters["refit_ms"] = Ms(Clock::now() - t0);
}
// Args: samples, refit growth (per mille), sparse_above (0: exact).
BENCHMARK(BM_RecStepAtSize)
    ->ArgsProduct({{100, 300, 500, 1000}, {0, 50}, {0}})
    ->Args({500, 50, 300})
    ->Args({1000, 50, 500})
    ->Args({2000, 50, 0})
    ->Args({2000, 50, 500})
    ->Args({10000, 50, 500})
    ->Iterations(40)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// One plan-and-apply plan from rest (a fresh planner: no warm start, first-call
// starts), on a fitted model.
void BM_PaPlan(benchmark::State& state) {
  const gp::DynamicsModel model = FittedPendulumModel(PendulumData(300), 300);
  double iterations = 0.0, entropy = 0.0;
  for (auto _ : state) {
    Planner planner(PendulumOptions(Strategy::kPa));
    PlanSummary summary;
    auto plan =
        planner.PlanInputs(model, Eigen::Vector2d(0.0, 0.0), 0, PlanLimits{}, &summary);
    if (!plan.ok()) {
      state.SkipWithError("plan failed");
      break;
    }
    iterations += summary.iterations;
    entropy += summary.objective;
    benchmark::DoNotOptimize(plan->inputs.data());
  }
  const auto avg = benchmark::Counter::kAvgIterations;
  state.counters["ipopt_iters"] = benchmark::Counter(iterations, avg);
  state.counters["entropy"] = benchmark::Counter(entropy, avg);
}
BENCHMARK(BM_PaPlan)->Iterations(10)->Unit(benchmark::kMillisecond)->UseRealTime();

// One sep plan from rest on a fitted model: the entropy search (multi-start
// L-BFGS-B over the region x input bounds) and the Ipopt steering towards x*.
void BM_SepPlan(benchmark::State& state) {
  const gp::DynamicsModel model = FittedPendulumModel(PendulumData(300), 300);
  PlanOptions options = PendulumOptions(Strategy::kSep);
  options.state_lower = Eigen::Vector2d(-3.141592653589793, -8.0);
  options.state_upper = Eigen::Vector2d(3.141592653589793, 8.0);
  Planner planner(options);
  double iterations = 0.0, steps = 0.0, search_entropy = 0.0;
  for (auto _ : state) {
    PlanSummary summary;
    auto plan =
        planner.PlanInputs(model, Eigen::Vector2d(0.0, 0.0), 0, PlanLimits{}, &summary);
    if (!plan.ok()) {
      state.SkipWithError("plan failed");
      break;
    }
    iterations += summary.iterations;
    steps += static_cast<double>(plan->inputs.rows());
    search_entropy += summary.search_entropy;
    benchmark::DoNotOptimize(plan->inputs.data());
  }
  const auto avg = benchmark::Counter::kAvgIterations;
  state.counters["iters"] = benchmark::Counter(iterations, avg);
  state.counters["inputs"] = benchmark::Counter(steps, avg);
  state.counters["search_entropy"] = benchmark::Counter(search_entropy, avg);
}
BENCHMARK(BM_SepPlan)->Iterations(10)->Unit(benchmark::kMillisecond)->UseRealTime();

// The model alone: one batched Predict of M = 15 points with Jacobians (what one
// NLP evaluation costs) at n = 300.
void BM_PredictWithJacobians(benchmark::State& state) {
  const gp::DynamicsModel model = FittedPendulumModel(PendulumData(300), 300);
  const Eigen::MatrixXd z = Eigen::MatrixXd::Random(15, 3);
  Eigen::MatrixXd mean, variance;
  std::vector<Eigen::MatrixXd> jm, jv;
  for (auto _ : state) {
    model.Predict(z, &mean, &variance, &jm, &jv);
    benchmark::DoNotOptimize(mean.data());
  }
}
BENCHMARK(BM_PredictWithJacobians)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace excite::plan

BENCHMARK_MAIN();
