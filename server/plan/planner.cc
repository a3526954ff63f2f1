#include "server/plan/planner.h"

#include <IpTNLP.hpp>
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "server/plan/entropy_objective.h"
#include "server/plan/ipopt_solve.h"
#include "server/plan/multiple_shooting_nlp.h"

namespace excite::plan {
namespace {

using Clock = std::chrono::steady_clock;

// Ipopt's obj_scaling_factor for -sum H. Entropy gradients are small (~0.1 per
// variable at typical starts), so with a limited-memory Hessian (initialised to
// the identity) Ipopt creeps along in tiny steps. Measured on the pendulum GP at
// n = 300, M = 15 (bench/plan, 12 rec steps, 2 starts): scaling 1 -> 84
// iterations per call, mean entropy -50.36; 10 -> 26, -50.36; 30 -> 18, -50.23;
// 100 -> 16, -50.23. The tolerance then applies to the scaled dual infeasibility,
// i.e. it is tighter, not looser.
constexpr double kObjectiveScaling = 100.0;

// A candidate plan: inputs rolled out exactly through the model mean.
struct Candidate {
  Eigen::MatrixXd inputs;
  Eigen::MatrixXd states;
  Eigen::MatrixXd variances;
  double entropy = -std::numeric_limits<double>::infinity();
  int start = -1;  // index of the start it came from
  bool valid = false;
};

// Rolls `inputs` (M x du) out from x0 through the model mean: states x_0..x_{M-1}
// and the variances at (x_i, u_i). M sequential one-point Predict calls.
Candidate Rollout(const gp::DynamicsPredictor& model, const Eigen::VectorXd& x0,
                  const Eigen::MatrixXd& inputs) {
  const int horizon = static_cast<int>(inputs.rows());
  const int dx = model.state_dim();
  const int du = model.input_dim();
  Candidate c;
  c.inputs = inputs;
  c.states.resize(horizon, dx);
  c.variances.resize(horizon, dx);
  Eigen::MatrixXd z(1, dx + du);
  Eigen::MatrixXd mean;
  Eigen::MatrixXd variance;
  Eigen::VectorXd x = x0;
  for (int i = 0; i < horizon; ++i) {
    c.states.row(i) = x.transpose();
    z.row(0).head(dx) = x.transpose();
    z.row(0).tail(du) = inputs.row(i);
    model.Predict(z, &mean, &variance, nullptr, nullptr);
    if (mean.rows() != 1 || mean.cols() != dx || variance.rows() != 1 ||
        variance.cols() != dx) {
      return c;
    }
    c.variances.row(i) = variance.row(0);
    x = mean.row(0).transpose();
  }
  c.valid = c.states.allFinite() && c.variances.allFinite();
  if (c.valid) c.entropy = Entropy(c.variances);
  return c;
}

PlanStatus FromIpopt(Ipopt::ApplicationReturnStatus status) {
  switch (status) {
    case Ipopt::Solve_Succeeded:
    case Ipopt::Solved_To_Acceptable_Level:
    case Ipopt::Feasible_Point_Found:
      return PlanStatus::kConverged;
    case Ipopt::Maximum_Iterations_Exceeded:
      return PlanStatus::kIterationLimit;
    case Ipopt::User_Requested_Stop:
    case Ipopt::Maximum_CpuTime_Exceeded:
      return PlanStatus::kTimeLimit;
    default:
      return PlanStatus::kNotConverged;
  }
}

// Uniform in [0, 1) from 53 random bits: the same on every platform.
double Uniform01(std::mt19937_64& rng) {
  return static_cast<double>(rng() >> 11) * 0x1.0p-53;
}

}  // namespace

Planner::Planner(PlanOptions options) : options_(std::move(options)) {}

absl::StatusOr<Plan> Planner::PlanInputs(const gp::DynamicsPredictor& model,
                                         const Eigen::VectorXd& x0,
                                         const PlanLimits& limits, PlanSummary* summary) {
  const Clock::time_point begin = Clock::now();
  const int dx = model.state_dim();
  const int du = model.input_dim();
  if (x0.size() != dx) {
    return absl::InvalidArgumentError(
        absl::StrCat("x0 has ", x0.size(), " entries, the model's state has ", dx));
  }
  if (!x0.allFinite()) return absl::InvalidArgumentError("x0 is not finite");
  const Eigen::VectorXd& lower = options_.input_lower;
  const Eigen::VectorXd& upper = options_.input_upper;
  if (lower.size() != du || upper.size() != du) {
    return absl::InvalidArgumentError(
        absl::StrCat("input bounds have ", lower.size(), " and ", upper.size(),
                     " entries, the model's input has ", du));
  }
  if (!lower.allFinite() || !upper.allFinite() || (lower.array() > upper.array()).any()) {
    return absl::InvalidArgumentError("input bounds must be finite with lower <= upper");
  }
  if (options_.strategy != Strategy::kGreedy && options_.horizon < 1) {
    return absl::InvalidArgumentError("horizon must be >= 1");
  }
  if (options_.max_iterations < 0 || options_.restarts < 0 ||
      !(options_.tolerance > 0.0)) {
    return absl::InvalidArgumentError(
        "max_iterations and restarts must be >= 0, tolerance > 0");
  }
  const auto cancelled = [&limits] { return limits.cancelled && limits.cancelled(); };
  const auto past_deadline = [&limits] {
    return limits.deadline.has_value() && Clock::now() >= *limits.deadline;
  };
  // Any input sequence rolled out through the mean is a feasible plan, so once the
  // starts are rolled out a feasible plan exists: CANCELLED is returned only when
  // cancelled() is already true here; a later cancel (or the deadline) returns
  // the best plan so far with status kTimeLimit.
  if (cancelled()) return absl::CancelledError("planning cancelled before it started");

  const int horizon = options_.strategy == Strategy::kGreedy ? 1 : options_.horizon;
  const int apply_count = options_.strategy == Strategy::kPa ? horizon : 1;
  const uint64_t call = calls_++;

  // Starts: warm start (previous plan shifted by its apply_count, padded with
  // its last input), a mid-bound start on the first call, then random ones.
  std::vector<Eigen::MatrixXd> starts;
  if (previous_.has_value() && previous_->inputs.rows() > 0 &&
      previous_->inputs.cols() == du) {
    const Eigen::MatrixXd& prev = previous_->inputs;
    const int prev_rows = static_cast<int>(prev.rows());
    Eigen::MatrixXd warm(horizon, du);
    for (int i = 0; i < horizon; ++i) {
      warm.row(i) = prev.row(std::min(i + previous_->apply_count, prev_rows - 1));
    }
    starts.push_back(std::move(warm));
  } else {
    starts.push_back((0.5 * (lower + upper)).transpose().replicate(horizon, 1));
  }
  std::seed_seq seq{static_cast<uint32_t>(options_.seed),
                    static_cast<uint32_t>(options_.seed >> 32),
                    static_cast<uint32_t>(call), static_cast<uint32_t>(call >> 32)};
  std::mt19937_64 rng(seq);
  for (int r = 0; r < options_.restarts; ++r) {
    Eigen::MatrixXd random(horizon, du);
    for (int i = 0; i < horizon; ++i) {
      for (int l = 0; l < du; ++l) {
        random(i, l) = lower(l) + (upper(l) - lower(l)) * Uniform01(rng);
      }
    }
    starts.push_back(std::move(random));
  }

  // Every start, rolled out, is already a feasible plan: keep the best.
  Candidate best;
  std::vector<Candidate> initial;
  initial.reserve(starts.size());
  for (size_t s = 0; s < starts.size(); ++s) {
    starts[s] = starts[s]
                    .cwiseMax(lower.transpose().replicate(horizon, 1))
                    .cwiseMin(upper.transpose().replicate(horizon, 1));
    Candidate c = Rollout(model, x0, starts[s]);
    c.start = static_cast<int>(s);
    if (c.valid && c.entropy > best.entropy) best = c;
    initial.push_back(std::move(c));
  }

  PlanSummary local;
  std::vector<PlanStatus> start_status(starts.size(), PlanStatus::kNotConverged);
  bool stopped = false;
  const Eigen::MatrixXd lower_rows = lower.transpose().replicate(horizon, 1);
  const Eigen::MatrixXd upper_rows = upper.transpose().replicate(horizon, 1);
  for (size_t s = 0; s < starts.size(); ++s) {
    if (cancelled() || past_deadline()) {
      stopped = true;
      break;
    }
    if (!initial[s].valid) continue;  // the model is not finite along this start
    Ipopt::SmartPtr<MultipleShootingNlp> nlp =
        new MultipleShootingNlp(model, x0, lower, upper, starts[s], initial[s].states,
                                [&] { return cancelled() || past_deadline(); });
    IpoptSettings settings;
    settings.max_iterations = options_.max_iterations;
    settings.tolerance = options_.tolerance;
    settings.objective_scaling = kObjectiveScaling;
    const IpoptOutcome outcome =
        SolveTnlp(Ipopt::SmartPtr<Ipopt::TNLP>(Ipopt::GetRawPtr(nlp)), settings);
    ++local.starts;
    local.iterations += nlp->iterations();
    start_status[s] = FromIpopt(outcome.status);
    for (const Eigen::VectorXd* w : {&nlp->best_feasible(), &nlp->final_point()}) {
      if (w->size() != nlp->num_variables() || !w->allFinite()) continue;
      if (w == &nlp->final_point() && *w == nlp->best_feasible()) continue;  // done
      const Eigen::MatrixXd inputs =
          nlp->InputsOf(*w).cwiseMax(lower_rows).cwiseMin(upper_rows);
      Candidate c = Rollout(model, x0, inputs);
      c.start = static_cast<int>(s);
      if (c.valid && c.entropy > best.entropy) best = std::move(c);
    }
    if (nlp->stopped()) {
      stopped = true;
      break;
    }
  }

  if (!best.valid) {
    return absl::InternalError(
        "the model's predictions are not finite along any start: no plan");
  }
  Plan plan;
  plan.inputs = std::move(best.inputs);
  plan.states = std::move(best.states);
  plan.variances = std::move(best.variances);
  plan.apply_count = apply_count;
  previous_ = plan;

  local.status = stopped ? PlanStatus::kTimeLimit : start_status[best.start];
  local.objective = best.entropy;
  local.wall_time_ms =
      std::chrono::duration<double, std::milli>(Clock::now() - begin).count();
  if (summary != nullptr) *summary = local;
  return plan;
}

}  // namespace excite::plan
