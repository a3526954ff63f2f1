#ifndef EXCITE_SERVER_SESSION_SESSION_SPEC_H_
#define EXCITE_SERVER_SESSION_SESSION_SPEC_H_

#include <cstdint>
#include <string>

#include "server/gp/dynamics_model.h"
#include "server/gp/refit_schedule.h"
#include "server/plan/plan_types.h"

namespace excite::session {

// When a session refits its hyperparameters (lazily, at Predict or PlanInputs).
struct RefitPolicy {
  bool fit_kernel = true;  // false: fixed hyperparameters, never fitted
  bool never = false;      // fit once, then keep the hyperparameters
  gp::RefitSchedule schedule;
  int64_t min_samples = 2;  // Predict and PlanInputs need this many samples
  // A fitted kernel whose policy allows refits: the schedule decides.
  bool refits() const { return fit_kernel && !never; }
};

// Everything a session is configured with, in engine types: built once from a
// validated config by the API layer and kept by the session.
struct SessionSpec {
  int state_dim = 0;
  int input_dim = 0;
  gp::DynamicsModelOptions model;
  plan::PlanOptions plan;
  RefitPolicy refit;
  // A call's budget for its refit and plan, seconds.
  double time_budget_s = 10.0;
  // The validated config as the store keeps it: bytes only the API layer reads
  // (described back to clients unchanged).
  std::string config;

  // Lengthscales of each output's kernel: one per state and input, one more per
  // angle (its sine and cosine).
  int kernel_inputs() const {
    return state_dim + input_dim + static_cast<int>(model.angle_dims.size());
  }
};

}  // namespace excite::session

#endif  // EXCITE_SERVER_SESSION_SESSION_SPEC_H_
