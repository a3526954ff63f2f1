#ifndef EXCITE_SIM_EXPLORATION_RUN_H_
#define EXCITE_SIM_EXPLORATION_RUN_H_

#include <atomic>
#include <ostream>
#include <string>

#include "absl/status/statusor.h"
#include "client/excite_client.h"
#include "excite/v1/sim_config.pb.h"
#include "sim/plants/plant.h"
#include "sim/run_summary.h"

namespace excite::sim {

struct ExplorationOptions {
  // Session id to ask for; empty lets the server pick one.
  std::string session_id;
  // Keep the session on the server at the end (default: delete it, also on failure).
  bool keep_session = false;
  // Progress lines go here ("step <k> samples <n> rmse <r> plan_ms <p>"); may be null.
  std::ostream* log = nullptr;
  // The idealised reference design instead of the session's strategy: every sample
  // starts from a state x = UniformState(plant, session.state_bounds) with an
  // input u drawn uniformly from the input bounds (the evaluation set's
  // distribution, evaluation.h; PortableRandom(seed, stream 3)), and
  // records (x + e, u, plant.Step(x, u) + e'). No plant can follow it (it cannot
  // jump between states): it shows how much a strategy could still win. The
  // server is never asked to plan; the summary's strategy is "uniform".
  bool uniform_design = false;
  // Every stored transition as a CSV row here, once the server acknowledged it,
  // in the layout `excite add` reads (client/transition_csv.h): x (measured), u
  // (as applied), x_next (measured), sequence, under a header. May be null.
  std::ostream* trajectory = nullptr;
  // Set (e.g. by a SIGINT handler) to stop after the current step: the run ends
  // CANCELLED naming the samples stored, and the session is deleted unless
  // keep_session (what is stored stays stored until then). May be null.
  const std::atomic<bool>* interrupted = nullptr;
  // A session with session_id that exists already is deleted and created anew
  // (default: CreateSession's ALREADY_EXISTS ends the run).
  bool replace_session = false;
  // Continue the existing session session_id instead of creating one: its
  // samples stay, new ones are numbered after its last sequence number, the
  // plant starts from the last stored next_state (a measurement: the true state
  // is not stored, so the plant takes it as the true one), the measurement noise
  // continues past the draws the stored samples used, and the run collects until
  // the session holds `samples`. The session plans with its stored config, whose
  // dimensions must be the plant's (FAILED_PRECONDITION otherwise); NOT_FOUND if
  // there is no such session. The session is kept at the end: the run did not
  // create it. Coverage counts the stored samples by their measured states.
  bool resume_session = false;
  // > 0: a real-time plant. The plant steps on a wall clock at this rate in its
  // own loop and never waits for the server; beside it, a planner thread sends
  // the new transitions and asks for the next plan with the inputs the plant
  // applies meanwhile as pending_inputs, then installs the plan from the step it
  // starts at. The planner wakes just after a tick, so it commits the ticks a
  // round trip misses: ceil(L * realtime_hz) - 1, L the slowest of the last 5
  // AddData + PlanInputs round trips, at most the horizon (0 while L is below a
  // period: the plan starts from the measured state, as in lock-step). A tick with no
  // plan row for it holds the last input applied (the stated fallback). Until the
  // first plan arrives each tick applies an input drawn uniformly from the input
  // bounds, as the lock-step loop does before min_samples (random_steps), so a
  // run whose plans are never late applies the lock-step run's inputs. Every row
  // of a plan is applied until the next plan takes over, whatever its
  // apply_count. The summary's `realtime` counts the other ticks (from a plan,
  // fell back) and late plans.
  double realtime_hz = 0.0;
};

// Runs one exploration of `plant` against the server behind `client`, as `config`
// (already validated by ValidateSimConfig, overrides applied) describes:
//
//  1. CreateSession(config.session) (or resume_session); x = plant.initial_state
//     (zeros if empty); the
//     measured state is y = x + e, e ~ N(0, noise.variance) per dimension, drawn
//     from PortableRandom(session.seed, stream 1).
//  2. Until `samples` transitions: PlanInputs(y). While the session holds fewer than
//     refit.min_samples (default 2) samples the server answers FAILED_PRECONDITION;
//     then ONE input drawn uniformly from the input bounds (PortableRandom(seed,
//     stream 2)) is applied and we ask again (the run's summary counts these
//     random_steps). Otherwise the first apply_count planned inputs (1 for rec and
//     greedy, M for pa) are applied, each clipped to the input bounds.
//  3. Each applied input u: x' = plant.Step(x, u), y' = x' + e'; the transition
//     (state y, input u as applied, next_state y', sequence = index of the sample
//     from 0, timestamp = run start (Unix s) + index * dt, i.e. plant time) is sent
//     with AddData: one stream per applied chunk (split at evaluation points), and
//     the reply must count every transition as stored.
//  4. Whenever the sample count reaches a multiple of evaluation.every_samples (and
//     at the end), the RMSE of the model on the evaluation set (evaluation.h; one
//     batched Predict, latent mean) is recorded and a progress line logged.
//  5. Coverage of the region (session.state_bounds) by the true states x_0..x_N.
//
// plan_ms_p50 is the median client-side round trip of the successful PlanInputs
// calls. A PlanInputs that fails with DEADLINE_EXCEEDED (the server's time budget,
// usually spent in a long refit whose progress the server keeps) is retried up to
// 3 times (counted in plan_retries). Errors: any other failed call (with the call and the
// sample count in the message), a malformed reply, or a plant state that is no longer
// finite.
absl::StatusOr<RunSummary> RunExploration(client::ExciteClient& client,
                                          const Plant& plant, const v1::SimConfig& config,
                                          const ExplorationOptions& options);

}  // namespace excite::sim

#endif  // EXCITE_SIM_EXPLORATION_RUN_H_
