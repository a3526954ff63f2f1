#include "server/plan/shooting_solver.h"

#include <IpTNLP.hpp>
#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "server/plan/ipopt_solve.h"
#include "server/plan/multiple_shooting_nlp.h"

namespace excite::plan {
namespace {

// The stall rule of one start (ShootingSettings::stall_tolerance). A check, from
// iteration kFirstStallCheck on, every kStallCheckEvery iterations, costs a rollout:
// about two evaluations on the pendulum (M one-point predictions in a chain), whose
// solves mostly end within 10 iterations and then pay nothing for the rule.
class StallWatch {
 public:
  static constexpr int kStallCheckEvery = 5;
  static constexpr int kFirstStallCheck = 10;

  StallWatch(double tolerance, int window) : tolerance_(tolerance), window_(window) {}

  // Called once per Ipopt iteration: true if this iteration's point is to be checked.
  bool CheckDue() {
    ++iteration_;
    return tolerance_ > 0.0 && iteration_ >= kFirstStallCheck &&
           iteration_ % kStallCheckEvery == 0;
  }

  // The checked rollout's safe-box violation and objective (lower is better, a
  // smaller violation first); true once the best has not improved by the tolerance
  // for `window` iterations.
  bool Stalled(double violation, double value) {
    if (std::isfinite(value)) {
      const bool less_violating = violation < best_violation_;
      const bool as_violating = violation == best_violation_;
      const double margin = tolerance_ * std::max(1.0, std::abs(best_value_));
      if (less_violating || (as_violating && value < best_value_ - margin)) {
        best_iteration_ = iteration_;
      }
      if (less_violating || (as_violating && value < best_value_)) {
        best_value_ = value;
        best_violation_ = violation;
      }
    }
    stalled_ = iteration_ - best_iteration_ >= window_;
    return stalled_;
  }

  bool stalled() const { return stalled_; }

 private:
  const double tolerance_;
  const int window_;
  int iteration_ = 0;
  int best_iteration_ = 0;
  double best_value_ = std::numeric_limits<double>::infinity();
  double best_violation_ = std::numeric_limits<double>::infinity();
  bool stalled_ = false;
};

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

}  // namespace

double RolloutObjective(const ShootingObjective& objective, const Rollout& rollout) {
  return objective.Evaluate(PointsOf(rollout), rollout.means, rollout.variances, nullptr,
                            nullptr, nullptr);
}

ShootingResult SolveFromStarts(const gp::DynamicsPredictor& model,
                               const ShootingObjective& objective,
                               const Eigen::VectorXd& x0, const Eigen::VectorXd& lower,
                               const Eigen::VectorXd& upper,
                               std::vector<Eigen::MatrixXd> starts,
                               const ShootingSettings& settings,
                               const std::function<bool()>& stop) {
  ShootingResult result;
  const auto consider = [&](Rollout r, int start) {
    if (!r.valid) return;
    const double value = RolloutObjective(objective, r);
    if (!std::isfinite(value)) return;
    const double violation = SafeBoxViolation(settings.safe_box, r.means, r.variances);
    const bool better = result.best_start < 0 || violation < result.safe_box_violation ||
                        (violation == result.safe_box_violation && value < result.value);
    if (better) {
      result.value = value;
      result.safe_box_violation = violation;
      result.best = std::move(r);
      result.best_start = start;
    }
  };

  // Every start, rolled out, is already a feasible plan: keep the best.
  std::vector<bool> finite(starts.size(), false);
  std::vector<Eigen::MatrixXd> initial_states(starts.size());
  for (size_t s = 0; s < starts.size(); ++s) {
    const Eigen::Index horizon = starts[s].rows();
    starts[s] = starts[s]
                    .cwiseMax(lower.transpose().replicate(horizon, 1))
                    .cwiseMin(upper.transpose().replicate(horizon, 1));
    Rollout r = RollOut(model, x0, starts[s]);
    finite[s] = r.valid;
    initial_states[s] = r.states;
    consider(std::move(r), static_cast<int>(s));
  }

  std::vector<PlanStatus> start_status(starts.size(), PlanStatus::kNotConverged);
  const auto stopped = [&stop] { return stop && stop(); };
  for (size_t s = 0; s < starts.size(); ++s) {
    if (stopped()) {
      result.stopped = true;
      break;
    }
    if (!finite[s]) continue;  // the model is not finite along this start
    const Eigen::Index horizon = starts[s].rows();
    const Eigen::MatrixXd lower_rows = lower.transpose().replicate(horizon, 1);
    const Eigen::MatrixXd upper_rows = upper.transpose().replicate(horizon, 1);
    Ipopt::SmartPtr<MultipleShootingNlp> nlp;
    const auto roll_out = [&](const Eigen::VectorXd& w) {
      const Eigen::MatrixXd inputs =
          nlp->InputsOf(w).cwiseMax(lower_rows).cwiseMin(upper_rows);
      Hallucination hallucination{settings.optimism_beta,
                                  nlp->EtaOf(w).cwiseMax(-1.0).cwiseMin(1.0)};
      return RollOut(model, x0, inputs,
                     settings.optimism_beta > 0.0 ? &hallucination : nullptr);
    };
    // Polled by the NLP once per iteration; a stalled start ends like a converged
    // one, and the next start runs.
    StallWatch stall(settings.stall_tolerance, settings.max_iterations / 10);
    const auto stop_or_stall = [&] {
      if (stopped()) return true;
      if (!stall.CheckDue()) return false;
      const Eigen::VectorXd w = nlp->last_point();
      if (w.size() != nlp->num_variables()) return false;
      Rollout r = roll_out(w);
      if (!r.valid) return false;
      const bool stalled =
          stall.Stalled(SafeBoxViolation(settings.safe_box, r.means, r.variances),
                        RolloutObjective(objective, r));
      consider(std::move(r), static_cast<int>(s));
      return stalled;
    };
    nlp = new MultipleShootingNlp(model, objective, x0, lower, upper, starts[s],
                                  initial_states[s], stop_or_stall);
    nlp->SetSafeBox(settings.safe_box);
    nlp->SetOptimism(settings.optimism_beta);
    IpoptSettings ipopt;
    ipopt.max_iterations = settings.max_iterations;
    ipopt.tolerance = settings.tolerance;
    ipopt.objective_scaling = settings.objective_scaling;
    const IpoptOutcome outcome =
        SolveTnlp(Ipopt::SmartPtr<Ipopt::TNLP>(Ipopt::GetRawPtr(nlp)), ipopt);
    ++result.starts;
    result.iterations += nlp->iterations();
    start_status[s] =
        stall.stalled() ? PlanStatus::kConverged : FromIpopt(outcome.status);
    for (const Eigen::VectorXd* w : {&nlp->best_feasible(), &nlp->final_point()}) {
      if (w->size() != nlp->num_variables() || !w->allFinite()) continue;
      if (w == &nlp->final_point() && *w == nlp->best_feasible()) continue;  // done
      consider(roll_out(*w), static_cast<int>(s));
    }
    if (nlp->stopped() && !stall.stalled()) {
      result.stopped = true;
      break;
    }
  }
  if (result.best_start >= 0) {
    result.status = result.stopped ? PlanStatus::kTimeLimit
                                   : start_status[static_cast<size_t>(result.best_start)];
  } else if (result.stopped) {
    result.status = PlanStatus::kTimeLimit;
  }
  return result;
}

}  // namespace excite::plan
