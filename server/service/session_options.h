#ifndef EXCITE_SERVER_SERVICE_SESSION_OPTIONS_H_
#define EXCITE_SERVER_SERVICE_SESSION_OPTIONS_H_

#include "excite/v1/session_config.pb.h"
#include "server/gp/dynamics_model.h"
#include "server/plan/planner.h"
#include "server/session/session_spec.h"

namespace excite::service {

// Translation of a validated SessionConfig into the engine's options (the only
// place where proto config meets engine structs).

// GP model options: target, noise, kernel fit or fixed hyperparameters, fit
// bounds/restarts/iterations, seed; inputs z = (x, u) normalised by the centre
// and half-width of state_bounds (NaN, i.e. "from the data", where there are no
// state_bounds) and input_bounds.
gp::DynamicsModelOptions ModelOptionsFromConfig(const v1::SessionConfig& config);

// Planner options: strategy, horizon, input bounds, state bounds (when there are
// state_dim of them), Ipopt iterations, restarts, tolerance, seed, signal and sep
// parameters (0 = the engine's default).
plan::PlanOptions PlanOptionsFromConfig(const v1::SessionConfig& config);

// Everything a session is configured with (server/session), from a validated
// config (or one as stored): model and plan options as above, the refit policy,
// the time budget, and the config's serialized bytes.
session::SessionSpec SessionSpecFromConfig(const v1::SessionConfig& config);

// proto <-> engine hyperparameters (data units).
gp::Hyperparameters FromProto(const v1::Hyperparameters& proto);
v1::Hyperparameters ToProto(const gp::Hyperparameters& hyperparameters);

}  // namespace excite::service

#endif  // EXCITE_SERVER_SERVICE_SESSION_OPTIONS_H_
