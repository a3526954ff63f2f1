#include "sim/exploration_run.h"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <deque>
#include <thread>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/strip.h"
#include "absl/synchronization/mutex.h"
#include "client/transition_csv.h"
#include "server/service/strategy_names.h"
#include "sim/evaluation.h"
#include "sim/input_schedule.h"
#include "sim/portable_random.h"
#include "sim/sim_config.h"

namespace excite::sim {
namespace {

using Clock = std::chrono::steady_clock;

// PlanInputs calls retried after DEADLINE_EXCEEDED before the run fails.
constexpr int kPlanRetries = 3;

double MillisecondsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

absl::Status Annotate(const absl::Status& status, absl::string_view context) {
  return absl::Status(status.code(), absl::StrCat(context, ": ", status.message()));
}

// Multi-step errors: 50 trajectories (RMSE Monte-Carlo error of ~10 %), scored
// after 10 and 30 steps (the horizons; the paper plans 10-15 ahead).
constexpr int kRolloutTrajectories = 50;
constexpr std::array<int, 2> kRolloutSteps = {10, 30};

// The state of one run; RunExploration's steps as methods.
class ExplorationRun {
 public:
  ExplorationRun(client::ExciteClient& client, const Plant& plant,
                 const v1::SimConfig& config, const ExplorationOptions& options)
      : client_(client),
        plant_(plant),
        config_(config),
        options_(options),
        dx_(plant.state_dim()),
        du_(plant.input_dim()),
        region_(BoxOf(config.session().state_bounds())),
        angle_dims_(config.session().angle_dims().begin(),
                    config.session().angle_dims().end()),
        input_box_(BoxOf(config.session().input_bounds())),
        noise_stddev_(std::sqrt(config.session().noise().variance())),
        noise_random_(config.session().seed(), 1),
        input_random_(config.session().seed(), 2),
        design_random_(config.session().seed(), 3) {}

  absl::StatusOr<RunSummary> Run();
  bool keeps_session() const { return options_.keep_session || options_.resume_session; }
  const std::string& session_name() const { return session_name_; }

 private:
  // CreateSession (with replace_session), or the session to resume.
  absl::StatusOr<v1::Session> OpenSession();
  // resume_session: the stored samples' count, sequences, last state and states.
  absl::StatusOr<v1::Session> Resume();
  absl::Status Explore();
  // The plant's first state (or the resumed one) and its measurement.
  void StartPlant();
  // ExplorationOptions::realtime_hz.
  absl::Status ExploreInRealTime();
  // Sends `batch` (one AddData) after which the session must hold `expected`
  // samples; writes the trajectory.
  absl::Status Send(const std::vector<v1::Transition>& batch, int64_t expected);
  // The plan's inputs as a horizon x input_dim matrix, each clipped to the input
  // box; INTERNAL for a malformed reply.
  absl::StatusOr<Eigen::MatrixXd> PlannedInputs(const v1::PlanInputsResponse& plan);
  // ExplorationOptions::uniform_design.
  absl::Status ExploreUniformly();
  // Applies u for one sampling period and queues the transition.
  absl::Status ApplyInput(const Eigen::VectorXd& u);
  // Sends the queued transitions (one AddData stream) and evaluates if due.
  absl::Status FlushAndMaybeEvaluate();
  // Appends `stored` to options_.trajectory (the header first).
  void WriteTrajectory(const std::vector<v1::Transition>& stored);
  absl::Status Evaluate(int64_t samples);
  // The summary's multi-step errors: the model's mean rolled out open loop along
  // rollouts_, one Predict per step for all trajectories; their RMSE after 10
  // and 30 steps into *rmse_10 and *rmse_30.
  absl::Status RollOut(double* rmse_10, double* rmse_30);
  Eigen::VectorXd Measure(const Eigen::VectorXd& x);

  client::ExciteClient& client_;
  const Plant& plant_;
  const v1::SimConfig& config_;
  const ExplorationOptions& options_;
  const int dx_;
  const int du_;
  const Box region_;
  const std::vector<int> angle_dims_;  // state dimensions on the circle
  const Box input_box_;
  const double noise_stddev_;
  PortableRandom noise_random_;
  PortableRandom input_random_;
  PortableRandom design_random_;

  std::string session_name_;
  int64_t min_samples_ = 2;
  EvaluationSet evaluation_set_;
  RolloutSet rollouts_;
  v1::PredictRequest predict_request_;
  Eigen::VectorXd x_;  // True state.
  Eigen::VectorXd y_;  // Its measurement.
  std::vector<Eigen::VectorXd> visited_;
  std::vector<v1::Transition> pending_;
  bool trajectory_header_written_ = false;
  int64_t samples_ = 0;
  // A transition's sequence number is sequence_offset_ + its sample index
  // (resume_session: after the stored ones).
  int64_t sequence_offset_ = 0;
  std::string strategy_name_;
  double start_unix_s_ = 0.0;
  std::vector<double> plan_ms_;
  int64_t random_steps_ = 0;
  int64_t plan_retries_ = 0;
  int horizon_ = 1;  // the session's planning horizon
  RunSummary summary_;
};

Eigen::VectorXd ExplorationRun::Measure(const Eigen::VectorXd& x) {
  Eigen::VectorXd y = x;
  for (int i = 0; i < dx_; ++i) y(i) += noise_stddev_ * noise_random_.Normal();
  return y;
}

absl::StatusOr<RunSummary> ExplorationRun::Run() {
  const auto start = Clock::now();
  start_unix_s_ =
      std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch())
          .count();
  const v1::EvaluationConfig& evaluation = config_.evaluation();
  absl::StatusOr<EvaluationSet> set = MakeEvaluationSet(
      plant_, region_, input_box_, evaluation.points(), evaluation.seed());
  if (!set.ok()) return Annotate(set.status(), "evaluation set");
  evaluation_set_ = *std::move(set);
  absl::StatusOr<RolloutSet> rollouts =
      MakeRolloutSet(plant_, region_, input_box_, kRolloutTrajectories,
                     kRolloutSteps.back(), evaluation.seed() + 1);
  if (!rollouts.ok()) return Annotate(rollouts.status(), "rollout set");
  rollouts_ = *std::move(rollouts);

  absl::StatusOr<v1::Session> session = OpenSession();
  if (!session.ok()) return session.status();
  session_name_ = session->name();
  // The server fills the defaults into the config it returns; 2 is the documented
  // default should it not.
  min_samples_ = session->config().refit().min_samples() > 0
                     ? session->config().refit().min_samples()
                 : config_.session().refit().min_samples() > 0
                     ? config_.session().refit().min_samples()
                     : 2;

  horizon_ = std::max(1, session->config().horizon());
  predict_request_.set_session(session_name_);
  predict_request_.set_include_noise(false);
  for (Eigen::Index p = 0; p < evaluation_set_.inputs.rows(); ++p) {
    for (Eigen::Index j = 0; j < evaluation_set_.inputs.cols(); ++j) {
      predict_request_.add_inputs(evaluation_set_.inputs(p, j));
    }
  }

  absl::Status explored = Explore();
  // A resumed session that already held its samples is still scored once.
  if (explored.ok() && summary_.rmse_history.empty() && samples_ >= min_samples_) {
    explored = Evaluate(samples_);
  }
  if (explored.ok()) {
    explored = RollOut(&summary_.rollout_rmse_10, &summary_.rollout_rmse_30);
  }
  // What became of the session, for a failure's message.
  std::string left =
      absl::StrCat("the session is kept: continue it with --resume --session_id=",
                   absl::StripPrefix(session_name_, "sessions/"));
  if (!keeps_session()) {
    const absl::Status deleted = client_.DeleteSession(session_name_);
    if (explored.ok() && !deleted.ok()) {
      explored = Annotate(deleted, absl::StrCat("DeleteSession ", session_name_));
    }
    left = deleted.ok()
               ? "the session was deleted"
               : absl::StrCat("deleting the session failed: ", deleted.message());
  }
  if (!explored.ok()) {
    return Annotate(explored, absl::StrCat(session_name_, " after ", samples_,
                                           " samples (", left, ")"));
  }

  Eigen::MatrixXd visited(static_cast<Eigen::Index>(visited_.size()), dx_);
  for (size_t n = 0; n < visited_.size(); ++n) {
    visited.row(static_cast<Eigen::Index>(n)) = visited_[n].transpose();
  }
  absl::StatusOr<Coverage> coverage =
      ComputeCoverage(OnTheCircle(visited, region_.lower, angle_dims_), region_,
                      evaluation.marginal_bins(), evaluation.joint_bins());
  if (!coverage.ok()) return Annotate(coverage.status(), "coverage");

  summary_.system = config_.system();
  summary_.state_names.assign(config_.session().state_names().begin(),
                              config_.session().state_names().end());
  summary_.state_units.assign(config_.session().state_units().begin(),
                              config_.session().state_units().end());
  summary_.strategy = options_.uniform_design ? "uniform" : strategy_name_;
  summary_.session = session_name_;
  summary_.samples = samples_;
  summary_.final_rmse =
      summary_.rmse_history.empty() ? NAN : summary_.rmse_history.back().rmse;
  summary_.coverage_marginal = coverage->marginal;
  summary_.coverage_joint = coverage->joint;
  summary_.plan_ms_p50 = Median(plan_ms_);
  summary_.plan_ms_p90 = Quantile(plan_ms_, 0.9);
  summary_.plan_ms_p99 = Quantile(plan_ms_, 0.99);
  summary_.plans = static_cast<int64_t>(plan_ms_.size());
  summary_.random_steps = random_steps_;
  summary_.plan_retries = plan_retries_;
  if (const v1::SafetyConfig& safety = config_.session().safety();
      safety.state_bounds_size() == dx_) {
    Box safe{Eigen::VectorXd(dx_), Eigen::VectorXd(dx_)};
    for (int j = 0; j < dx_; ++j) {
      safe.lower(j) = safety.state_bounds(j).lower();
      safe.upper(j) = safety.state_bounds(j).upper();
    }
    summary_.left_safe_box =
        FractionOutside(OnTheCircle(visited, safe.lower, angle_dims_), safe);
  }
  summary_.wall_s = MillisecondsSince(start) / 1000.0;
  return summary_;
}

absl::StatusOr<v1::Session> ExplorationRun::OpenSession() {
  if (options_.resume_session) return Resume();
  strategy_name_ = service::StrategyShortName(config_.session().strategy());
  absl::StatusOr<v1::Session> session =
      client_.CreateSession(config_.session(), options_.session_id);
  if (!session.ok() && session.status().code() == absl::StatusCode::kAlreadyExists &&
      options_.replace_session) {
    const std::string existing = absl::StrCat("sessions/", options_.session_id);
    if (absl::Status s = client_.DeleteSession(existing); !s.ok()) {
      return Annotate(s, absl::StrCat("DeleteSession ", existing, " (--replace)"));
    }
    if (options_.log != nullptr) *options_.log << "replaced " << existing << "\n";
    session = client_.CreateSession(config_.session(), options_.session_id);
  }
  if (!session.ok()) return Annotate(session.status(), "CreateSession");
  return session;
}

absl::StatusOr<v1::Session> ExplorationRun::Resume() {
  const std::string name = absl::StrCat("sessions/", options_.session_id);
  absl::StatusOr<v1::SessionArchive> archive = client_.ExportSession(name);
  if (!archive.ok()) {
    if (archive.status().code() == absl::StatusCode::kNotFound) {
      return absl::NotFoundError(
          absl::StrCat("--resume: there is no session ", name,
                       " to continue (start one without --resume)"));
    }
    return Annotate(archive.status(),
                    absl::StrCat("ExportSession ", name, " (--resume)"));
  }
  const v1::SessionConfig& stored = archive->config();
  if (stored.state_dim() != dx_ || stored.input_dim() != du_) {
    return absl::FailedPreconditionError(
        absl::StrCat("--resume: session ", name, " has state_dim ", stored.state_dim(),
                     " and input_dim ", stored.input_dim(), "; the ", plant_.name(),
                     " has ", dx_, " and ", du_));
  }
  strategy_name_ = service::StrategyShortName(stored.strategy());
  samples_ = archive->samples_size();
  x_ = Eigen::VectorXd::Zero(dx_);
  for (int i = 0; i < config_.plant().initial_state_size(); ++i) {
    x_(i) = config_.plant().initial_state(i);
  }
  for (const v1::Transition& t : archive->samples()) {
    visited_.push_back(Eigen::Map<const Eigen::VectorXd>(t.state().data(), dx_));
  }
  if (samples_ > 0) {
    const v1::Transition& last = archive->samples(static_cast<int>(samples_ - 1));
    x_ = Eigen::Map<const Eigen::VectorXd>(last.next_state().data(), dx_);
    sequence_offset_ = last.sequence() + 1 - samples_;
  }
  // The stored samples used one measurement each, and the first state one.
  for (int64_t k = 0; k < (samples_ + 1) * dx_; ++k) noise_random_.Normal();
  if (options_.log != nullptr) {
    *options_.log << "resuming " << name << " at " << samples_ << " samples\n";
  }
  absl::StatusOr<v1::Session> session = client_.GetSession(name);
  if (!session.ok()) return Annotate(session.status(), absl::StrCat("GetSession ", name));
  return session;
}

absl::Status ExplorationRun::ExploreUniformly() {
  const int64_t target = config_.samples();
  const int64_t every = config_.evaluation().every_samples();
  while (samples_ < target) {
    absl::StatusOr<Eigen::VectorXd> x = UniformState(plant_, region_, design_random_);
    if (!x.ok()) return Annotate(x.status(), "uniform design");
    x_ = *std::move(x);
    y_ = Measure(x_);
    visited_.push_back(x_);
    if (absl::Status s = ApplyInput(UniformPoint(input_box_, design_random_)); !s.ok()) {
      return s;
    }
    // The next state is not where the next sample starts: only the drawn states
    // count as visited.
    visited_.pop_back();
    if (samples_ % every == 0 || samples_ == target) {
      if (absl::Status s = FlushAndMaybeEvaluate(); !s.ok()) return s;
    }
  }
  return FlushAndMaybeEvaluate();
}

void ExplorationRun::StartPlant() {
  if (options_.resume_session) {
    y_ = x_;  // the stored measurement; the plant continues from it
  } else {
    x_ = Eigen::VectorXd::Zero(dx_);
    for (int i = 0; i < config_.plant().initial_state_size(); ++i) {
      x_(i) = config_.plant().initial_state(i);
    }
    y_ = Measure(x_);
    visited_.push_back(x_);
  }
}

absl::Status ExplorationRun::Explore() {
  if (options_.uniform_design) return ExploreUniformly();
  if (options_.realtime_hz > 0) return ExploreInRealTime();
  const int64_t target = config_.samples();
  StartPlant();

  while (samples_ < target) {
    if (options_.interrupted != nullptr && options_.interrupted->load()) {
      return absl::CancelledError(
          absl::StrCat("interrupted after ", samples_, " stored samples"));
    }
    std::vector<Eigen::VectorXd> inputs;
    const auto plan_start = Clock::now();
    absl::StatusOr<v1::PlanInputsResponse> plan = client_.PlanInputs(
        session_name_, std::vector<double>(y_.data(), y_.data() + dx_));
    // A plan that missed the server's time budget (typically a long refit) is
    // retried: the server keeps the refit's progress, so the retry is shorter.
    for (int retry = 1; retry <= kPlanRetries && !plan.ok() &&
                        plan.status().code() == absl::StatusCode::kDeadlineExceeded;
         ++retry) {
      if (options_.log != nullptr) {
        *options_.log << absl::StrFormat(
            "PlanInputs missed its deadline at %d samples (%s); retry %d of %d\n",
            samples_, plan.status().message(), retry, kPlanRetries);
      }
      ++plan_retries_;
      plan = client_.PlanInputs(session_name_,
                                std::vector<double>(y_.data(), y_.data() + dx_));
    }
    if (!plan.ok()) {
      if (plan.status().code() != absl::StatusCode::kFailedPrecondition ||
          samples_ >= min_samples_) {
        return Annotate(plan.status(), "PlanInputs");
      }
      // Too little data to plan: one uniformly random input.
      Eigen::VectorXd u(du_);
      for (int j = 0; j < du_; ++j) {
        u(j) = input_random_.Uniform(input_box_.lower(j), input_box_.upper(j));
      }
      inputs.push_back(u);
      ++random_steps_;
    } else {
      plan_ms_.push_back(MillisecondsSince(plan_start));
      ++summary_.planned_by[service::StrategyShortName(plan->planned_by())];
      absl::StatusOr<Eigen::MatrixXd> planned = PlannedInputs(*plan);
      if (!planned.ok()) return planned.status();
      for (int i = 0; i < plan->apply_count(); ++i) {
        inputs.push_back(planned->row(i).transpose());
      }
    }
    for (const Eigen::VectorXd& u : inputs) {
      if (samples_ >= target) break;
      if (absl::Status s = ApplyInput(u); !s.ok()) return s;
      const int64_t every = config_.evaluation().every_samples();
      if (samples_ % every == 0 || samples_ == target) {
        if (absl::Status s = FlushAndMaybeEvaluate(); !s.ok()) return s;
      }
    }
    if (absl::Status s = FlushAndMaybeEvaluate(); !s.ok()) return s;
  }
  return absl::OkStatus();
}

absl::StatusOr<Eigen::MatrixXd> ExplorationRun::PlannedInputs(
    const v1::PlanInputsResponse& plan) {
  const int horizon = plan.horizon();
  const int apply = plan.apply_count();
  if (horizon < 1 || plan.inputs_size() != horizon * du_ || apply < 1 ||
      apply > horizon) {
    return absl::InternalError(absl::StrCat(
        "PlanInputs: malformed reply (horizon ", horizon, ", apply_count ", apply, ", ",
        plan.inputs_size(), " inputs for input_dim ", du_, ")"));
  }
  Eigen::MatrixXd inputs(horizon, du_);
  for (int i = 0; i < horizon; ++i) {
    for (int j = 0; j < du_; ++j) {
      const double value = plan.inputs(i * du_ + j);
      if (!std::isfinite(value)) {
        return absl::InternalError("PlanInputs: non-finite planned input");
      }
      inputs(i, j) = std::clamp(value, input_box_.lower(j), input_box_.upper(j));
    }
  }
  return inputs;
}

absl::Status ExplorationRun::ExploreInRealTime() {
  const int64_t target = config_.samples();
  const int64_t every = config_.evaluation().every_samples();
  const double hz = options_.realtime_hz;
  StartPlant();
  // Until the first plan arrives, each tick draws a uniform input, as the
  // lock-step loop does while the server cannot plan yet: a real-time run whose
  // plans are never late applies exactly the lock-step run's inputs.
  const auto random_input = [this] {
    Eigen::VectorXd u(du_);
    for (int j = 0; j < du_; ++j) {
      u(j) = input_random_.Uniform(input_box_.lower(j), input_box_.upper(j));
    }
    return u;
  };
  InputSchedule schedule(Eigen::VectorXd::Zero(du_));
  bool planned = false;  // a plan has arrived
  absl::Mutex mu;        // the plant's state, the queue and the schedule
  bool done = false;
  absl::Status failure;
  RealtimeStats& stats = summary_.realtime;
  stats.hz = hz;

  // Planning beside the plant: send what was measured, commit the inputs the
  // plant applies while the plan is computed, plan from after them. The planner
  // wakes just after a tick, so a round trip of L seconds misses the next
  // ceil(L hz) - 1 ticks (L: the slowest of the last 5, the refits included).
  std::thread planner([&] {
    std::deque<double> round_trips_s;
    int64_t planned_at = -1;
    int64_t evaluated_block = samples_ / every;
    const auto stop = [&](absl::Status status) {
      absl::MutexLock lock(&mu);
      if (failure.ok()) failure = std::move(status);
    };
    while (true) {
      std::vector<v1::Transition> batch;
      Eigen::VectorXd y;
      int64_t step = 0;
      Eigen::MatrixXd pending;
      {
        const auto moved = [&] { return done || samples_ > planned_at; };
        absl::MutexLock lock(&mu, absl::Condition(&moved));
        if (done || !failure.ok()) return;
        batch.swap(pending_);
        y = y_;
        step = samples_;
        double slowest_s = 0.0;
        for (double s : round_trips_s) slowest_s = std::max(slowest_s, s);
        const int ahead =
            std::clamp(static_cast<int>(std::ceil(slowest_s * hz)) - 1, 0, horizon_);
        if (step >= min_samples_) pending = schedule.Commit(step, ahead);
      }
      const auto sent_at = Clock::now();
      if (absl::Status s = Send(batch, step); !s.ok()) return stop(s);
      if (step / every > evaluated_block && step >= min_samples_) {
        evaluated_block = step / every;
        if (absl::Status s = Evaluate(step); !s.ok()) return stop(s);
      }
      planned_at = step;
      if (step < min_samples_) continue;  // FAILED_PRECONDITION until then
      const auto plan_start = Clock::now();
      absl::StatusOr<v1::PlanInputsResponse> plan = client_.PlanInputs(
          session_name_, std::vector<double>(y.data(), y.data() + dx_),
          std::vector<double>(pending.data(), pending.data() + pending.size()));
      if (!plan.ok() && plan.status().code() == absl::StatusCode::kDeadlineExceeded) {
        ++plan_retries_;  // the plant holds on; plan again at the next sample
        continue;
      }
      if (!plan.ok()) return stop(Annotate(plan.status(), "PlanInputs"));
      absl::StatusOr<Eigen::MatrixXd> inputs = PlannedInputs(*plan);
      if (!inputs.ok()) return stop(inputs.status());
      if (plan->start_step() != pending.rows()) {
        return stop(absl::InternalError(absl::StrCat("PlanInputs: start_step ",
                                                     plan->start_step(), " for ",
                                                     pending.rows(), " pending inputs")));
      }
      plan_ms_.push_back(MillisecondsSince(plan_start));
      round_trips_s.push_back(MillisecondsSince(sent_at) / 1000.0);
      if (round_trips_s.size() > 5) round_trips_s.pop_front();
      ++summary_.planned_by[service::StrategyShortName(plan->planned_by())];
      absl::MutexLock lock(&mu);
      planned = true;
      if (!schedule.Install(step + pending.rows(), *inputs, samples_)) ++stats.late_plans;
    }
  });

  // The plant's clock: one step per tick, whatever the planner is doing.
  const auto period = std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double>(1.0 / hz));
  const Clock::time_point start = Clock::now();
  for (int64_t tick = 0;; ++tick) {
    std::this_thread::sleep_until(start + tick * period);
    if (Clock::now() > start + (tick + 1) * period) ++stats.overruns;
    absl::MutexLock lock(&mu);
    if (samples_ >= target || !failure.ok()) break;
    if (options_.interrupted != nullptr && options_.interrupted->load()) {
      failure = absl::CancelledError(
          absl::StrCat("interrupted after ", samples_, " stored samples"));
      break;
    }
    bool from_plan = false;
    Eigen::VectorXd u;
    if (planned) {
      u = schedule.Take(samples_, &from_plan);
      ++(from_plan ? stats.ticks_from_plan : stats.ticks_fell_back);
    } else {
      u = random_input();
      schedule.Hold(u);
      ++random_steps_;
    }
    if (absl::Status s = ApplyInput(u); !s.ok()) {
      failure = s;
      break;
    }
  }
  {
    absl::MutexLock lock(&mu);
    done = true;
  }
  planner.join();
  if (!failure.ok()) return failure;
  return FlushAndMaybeEvaluate();
}

absl::Status ExplorationRun::Send(const std::vector<v1::Transition>& batch,
                                  int64_t expected) {
  if (batch.empty()) return absl::OkStatus();
  absl::StatusOr<v1::AddDataResponse> reply = client_.AddData(session_name_, {batch});
  if (!reply.ok()) return Annotate(reply.status(), "AddData");
  if (reply->stored() + reply->duplicates() != static_cast<int64_t>(batch.size()) ||
      reply->sample_count() != expected) {
    return absl::DataLossError(absl::StrCat(
        "AddData stored ", reply->stored(), " of ", batch.size(), " transitions (",
        reply->duplicates(), " duplicates); the session has ", reply->sample_count(),
        " samples, expected ", expected));
  }
  if (options_.trajectory != nullptr) WriteTrajectory(batch);
  return absl::OkStatus();
}

absl::Status ExplorationRun::ApplyInput(const Eigen::VectorXd& u) {
  const Eigen::VectorXd x_next = plant_.Step(x_, u);
  if (!x_next.allFinite()) {
    return absl::InternalError(
        absl::StrCat("the ", plant_.name(), " state is no longer finite"));
  }
  const Eigen::VectorXd y_next = Measure(x_next);
  v1::Transition transition;
  for (int i = 0; i < dx_; ++i) transition.add_state(y_(i));
  for (int j = 0; j < du_; ++j) transition.add_input(u(j));
  for (int i = 0; i < dx_; ++i) transition.add_next_state(y_next(i));
  transition.set_sequence(sequence_offset_ + samples_);
  transition.set_timestamp_s(start_unix_s_ +
                             static_cast<double>(samples_) * config_.plant().dt_s());
  pending_.push_back(std::move(transition));
  x_ = x_next;
  y_ = y_next;
  visited_.push_back(x_);
  ++samples_;
  return absl::OkStatus();
}

absl::Status ExplorationRun::FlushAndMaybeEvaluate() {
  if (pending_.empty()) return absl::OkStatus();
  // A batch resent after a lost answer (a retry) comes back as duplicates.
  if (absl::Status s = Send(pending_, samples_); !s.ok()) return s;
  pending_.clear();
  const int64_t every = config_.evaluation().every_samples();
  if ((samples_ % every == 0 || samples_ == config_.samples()) &&
      samples_ >= min_samples_) {
    if (absl::Status s = Evaluate(samples_); !s.ok()) return s;
    if (summary_.midway_samples == 0 && 2 * samples_ >= config_.samples()) {
      summary_.midway_samples = samples_;
      summary_.midway_rmse = summary_.rmse_history.back().rmse;
      return RollOut(&summary_.midway_rollout_rmse_10, &summary_.midway_rollout_rmse_30);
    }
  }
  return absl::OkStatus();
}

void ExplorationRun::WriteTrajectory(const std::vector<v1::Transition>& stored) {
  std::ostream& out = *options_.trajectory;
  if (!trajectory_header_written_) {
    const v1::SessionConfig& session = config_.session();
    out << client::TransitionCsvHeader(
               dx_, du_, {session.state_names().begin(), session.state_names().end()},
               {session.input_names().begin(), session.input_names().end()})
        << "\n";
    trajectory_header_written_ = true;
  }
  for (const v1::Transition& t : stored) out << client::TransitionCsvRow(t) << "\n";
}

absl::Status ExplorationRun::RollOut(double* rmse_10, double* rmse_30) {
  const Eigen::Index count = rollouts_.states[0].rows();
  Eigen::MatrixXd x = rollouts_.states[0];
  v1::PredictRequest request;
  request.set_session(session_name_);
  request.set_include_noise(false);
  for (int k = 0; k < kRolloutSteps.back(); ++k) {
    request.clear_inputs();
    for (Eigen::Index r = 0; r < count; ++r) {
      for (int i = 0; i < dx_; ++i) request.add_inputs(x(r, i));
      for (int j = 0; j < du_; ++j) request.add_inputs(rollouts_.inputs[k](r, j));
    }
    absl::StatusOr<v1::PredictResponse> reply = client_.Predict(request);
    if (!reply.ok()) return Annotate(reply.status(), "Predict (rollout)");
    if (reply->mean_size() != count * dx_) {
      return absl::InternalError(absl::StrCat("Predict returned ", reply->mean_size(),
                                              " means for ", count, " rollouts"));
    }
    x = Eigen::Map<
        const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
        reply->mean().data(), count, dx_);
    double* scored = k + 1 == kRolloutSteps[0]   ? rmse_10
                     : k + 1 == kRolloutSteps[1] ? rmse_30
                                                 : nullptr;
    if (scored != nullptr) {
      absl::StatusOr<double> rmse = Rmse(x, rollouts_.states[k + 1], angle_dims_);
      if (!rmse.ok()) return rmse.status();
      *scored = *rmse;
    }
  }
  return absl::OkStatus();
}

absl::Status ExplorationRun::Evaluate(int64_t samples) {
  absl::StatusOr<v1::PredictResponse> reply = client_.Predict(predict_request_);
  if (!reply.ok()) return Annotate(reply.status(), "Predict");
  const Eigen::Index points = evaluation_set_.next_states.rows();
  if (reply->mean_size() != points * dx_) {
    return absl::InternalError(absl::StrCat("Predict returned ", reply->mean_size(),
                                            " means for ", points, " points"));
  }
  const Eigen::MatrixXd mean = Eigen::Map<
      const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
      reply->mean().data(), points, dx_);
  absl::StatusOr<double> rmse = Rmse(mean, evaluation_set_.next_states, angle_dims_);
  if (!rmse.ok()) return rmse.status();
  absl::StatusOr<Eigen::VectorXd> per_dimension =
      RmsePerDimension(mean, evaluation_set_.next_states, angle_dims_);
  if (!per_dimension.ok()) return per_dimension.status();
  summary_.final_rmse_per_dimension.assign(per_dimension->begin(), per_dimension->end());
  const Eigen::MatrixXd variance = Eigen::Map<
      const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
      reply->variance().data(), points, dx_);
  const Calibration calibration =
      ComputeCalibration(mean, variance, evaluation_set_.next_states, angle_dims_);
  summary_.final_nlpd = calibration.nlpd;
  summary_.final_inside_95 = calibration.inside_95;
  summary_.rmse_history.push_back({samples, *rmse});
  if (options_.log != nullptr) {
    *options_.log << absl::StrFormat("step %d samples %d rmse %.4f plan_ms %.1f\n",
                                     static_cast<int64_t>(plan_ms_.size()), samples,
                                     *rmse, plan_ms_.empty() ? 0.0 : plan_ms_.back())
                  << std::flush;
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<RunSummary> RunExploration(client::ExciteClient& client,
                                          const Plant& plant, const v1::SimConfig& config,
                                          const ExplorationOptions& options) {
  if (absl::Status s = ValidateSimConfig(config); !s.ok()) return s;
  if (plant.state_dim() != config.session().state_dim() ||
      plant.input_dim() != config.session().input_dim()) {
    return absl::InvalidArgumentError(
        "the plant's dims differ from the session config's");
  }
  if (options.resume_session &&
      (options.session_id.empty() || options.replace_session || options.uniform_design)) {
    return absl::InvalidArgumentError(
        "--resume needs --session_id, and goes with neither --replace nor the uniform "
        "design");
  }
  ExplorationRun run(client, plant, config, options);
  return run.Run();
}

}  // namespace excite::sim
