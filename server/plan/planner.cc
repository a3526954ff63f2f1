#include "server/plan/planner.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <random>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "server/gp/flush_denormals.h"
#include "server/plan/auto_planner.h"
#include "server/plan/plan_slots.h"
#include "server/plan/sep_planner.h"
#include "server/plan/shooting_solver.h"

namespace excite::plan {
namespace {

using Clock = std::chrono::steady_clock;

// Uniform in [0, 1) from 53 random bits: the same on every platform.
double Uniform01(std::mt19937_64& rng) {
  return static_cast<double>(rng() >> 11) * 0x1.0p-53;
}

}  // namespace

Planner::Planner(PlanOptions options) : options_(std::move(options)) {}
Planner::Planner(Planner&&) noexcept = default;
Planner& Planner::operator=(Planner&&) noexcept = default;
Planner::~Planner() = default;

absl::StatusOr<Plan> Planner::PlanInputs(const gp::DynamicsPredictor& model,
                                         const Eigen::VectorXd& x0, int64_t time_index,
                                         const PlanLimits& limits, PlanSummary* summary,
                                         const PlanStart& start) {
  const gp::ScopedFlushDenormals flush;  // Ipopt's and the model's arithmetic
  const Clock::time_point begin = Clock::now();
  const int dx = model.state_dim();
  const int du = model.input_dim();
  if (x0.size() != dx) {
    return absl::InvalidArgumentError(
        absl::StrCat("x0 has ", x0.size(), " entries, the model's state has ", dx));
  }
  if (!x0.allFinite()) return absl::InvalidArgumentError("x0 is not finite");
  if (time_index < 0) return absl::InvalidArgumentError("time_index must be >= 0");
  // The options, checked once per model shape (PlanOptions::Validate).
  if (!validated_for_.has_value() || *validated_for_ != std::make_pair(dx, du)) {
    options_status_ = options_.Validate(dx, du);
    validated_for_ = std::make_pair(dx, du);
  }
  if (!options_status_.ok()) return options_status_;
  const StrategyInfo& strategy = InfoOf(options_.strategy);
  const auto cancelled = [&limits] { return limits.cancelled && limits.cancelled(); };
  const auto past_deadline = [&limits] {
    return limits.deadline.has_value() && Clock::now() >= *limits.deadline;
  };
  // Any input sequence rolled out through the mean is a feasible plan, so once the
  // starts are rolled out a feasible plan exists: CANCELLED is returned only when
  // cancelled() is already true here; a later cancel (or the deadline) returns
  // the best plan so far with status kTimeLimit.
  if (cancelled()) return absl::CancelledError("planning cancelled before it started");
  const std::function<bool()> stop = [&] { return cancelled() || past_deadline(); };
  const uint64_t call = calls_++;

  PlanSummary local;
  local.planned_by = options_.strategy;
  PlanSlot slot;  // signals are instant: they take none
  if (strategy.method != PlanMethod::kSignal) {
    if (absl::Status s = slot.Acquire(limits.deadline, cancelled); !s.ok()) return s;
  }
  absl::StatusOr<Plan> plan;
  if (strategy.method == PlanMethod::kMembers) {
    if (auto_ == nullptr) auto_ = std::make_unique<AutoPlanner>(options_);
    plan = auto_->PlanInputs(model, x0, time_index, limits, start.measured, &local);
  } else if (strategy.method == PlanMethod::kSignal) {
    plan = PlanSignal(strategy, dx, time_index);
    local.status = PlanStatus::kConverged;
  } else if (strategy.method == PlanMethod::kSeparated) {
    std::seed_seq seq{static_cast<uint32_t>(options_.seed),
                      static_cast<uint32_t>(options_.seed >> 32),
                      static_cast<uint32_t>(call), static_cast<uint32_t>(call >> 32)};
    std::mt19937_64 rng(seq);
    plan = PlanSeparated(model, x0, options_, rng(), stop, &local);
  } else {
    plan = PlanTrajectory(strategy, model, x0, call, stop, start, &local);
  }
  if (!plan.ok()) return plan.status();
  local.wall_time_ms =
      std::chrono::duration<double, std::milli>(Clock::now() - begin).count();
  if (summary != nullptr) *summary = local;
  return plan;
}

Plan Planner::PlanSignal(const StrategyInfo& strategy, int state_dim,
                         int64_t time_index) const {
  Plan plan;
  plan.inputs = strategy.make_signal(options_, time_index);
  plan.states.resize(0, state_dim);
  plan.variances.resize(0, state_dim);
  plan.apply_count = static_cast<int>(plan.inputs.rows());
  return plan;
}

absl::StatusOr<Plan> Planner::PlanTrajectory(const StrategyInfo& strategy,
                                             const gp::DynamicsPredictor& model,
                                             const Eigen::VectorXd& x0, uint64_t call,
                                             const std::function<bool()>& stop,
                                             const PlanStart& start,
                                             PlanSummary* summary) {
  absl::StatusOr<std::unique_ptr<ShootingObjective>> objective =
      strategy.make_objective(model, options_, &reference_);
  if (!objective.ok()) return objective.status();
  const int du = model.input_dim();
  const Eigen::VectorXd& lower = options_.input_lower;
  const Eigen::VectorXd& upper = options_.input_upper;
  const int horizon =
      strategy.fixed_horizon > 0 ? strategy.fixed_horizon : options_.horizon;
  const int apply_count = strategy.apply_all ? horizon : 1;

  // Starts: warm start (previous plan shifted by the steps the plant moved on,
  // padded with its last input), a mid-bound start on the first call, then random
  // ones.
  std::vector<Eigen::MatrixXd> starts;
  if (previous_.has_value() && previous_->inputs.rows() > 0 &&
      previous_->inputs.cols() == du) {
    const Eigen::MatrixXd& prev = previous_->inputs;
    const int prev_rows = static_cast<int>(prev.rows());
    const int64_t shift =
        std::max<int64_t>(0, start.steps_since_previous.value_or(previous_->apply_count));
    Eigen::MatrixXd warm(horizon, du);
    for (int i = 0; i < horizon; ++i) {
      warm.row(i) = prev.row(
          static_cast<Eigen::Index>(std::min<int64_t>(i + shift, prev_rows - 1)));
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

  ShootingSettings settings;
  settings.max_iterations = options_.max_iterations;
  settings.tolerance = options_.tolerance;
  // Ten times Ipopt's tol: a 10x longer solve (10x the iterations, a 10x tighter
  // tol) also waits 10x longer for a 10x smaller improvement.
  settings.stall_tolerance = 10.0 * options_.tolerance;
  settings.objective_scaling = strategy.objective_scaling;
  settings.safe_box = options_.safe_box;
  if (strategy.optimistic_dynamics) {
    settings.optimism_beta = options_.optimism_beta;
  }
  ShootingResult result = SolveFromStarts(model, **objective, x0, lower, upper,
                                          std::move(starts), settings, stop);
  if (!result.best.valid) {
    return absl::InternalError(
        "the model's predictions are not finite along any start: no plan");
  }
  Plan plan;
  plan.inputs = std::move(result.best.inputs);
  plan.states = std::move(result.best.states);
  plan.variances = std::move(result.best.variances);
  plan.apply_count = apply_count;
  previous_ = plan;

  summary->status = result.status;
  summary->iterations = result.iterations;
  summary->starts = result.starts;
  summary->objective = -result.value;
  summary->safe_box_violation = result.safe_box_violation;
  return plan;
}

}  // namespace excite::plan
