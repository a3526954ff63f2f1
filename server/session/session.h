#ifndef EXCITE_SERVER_SESSION_SESSION_H_
#define EXCITE_SERVER_SESSION_SESSION_H_

#include <Eigen/Dense>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "absl/synchronization/mutex.h"
#include "server/gp/dynamics_model.h"
#include "server/plan/planner.h"
#include "server/plan/rollout.h"
#include "server/session/labels.h"
#include "server/session/learning_history.h"
#include "server/session/memory_budget.h"
#include "server/session/metrics_sink.h"
#include "server/session/session_spec.h"
#include "server/session/stored_format.h"
#include "server/store/session_store.h"
#include "server/store/store_records.h"

namespace excite::session {

// What Session::AddSamples did: this batch's new and duplicate samples, and the
// session after it.
struct AddResult {
  int64_t stored = 0;
  int64_t duplicates = 0;
  int64_t sample_count = 0;
  int64_t model_version = 0;
};

// Transitions as the model takes them, one row per sample.
struct TransitionRows {
  Eigen::MatrixXd states;
  Eigen::MatrixXd inputs;
  Eigen::MatrixXd next_states;
};

// One Session::Predict: a row per point, a column per state dimension.
struct Prediction {
  Eigen::MatrixXd mean;
  Eigen::MatrixXd variance;
  int64_t model_version = 0;
};

// One Session::Rollout: the propagated state distribution and the model version.
struct RolloutResult {
  plan::PropagatedTrajectory trajectory;
  int64_t model_version = 0;
};

// Session::ExportModel: what the model's predictions depend on, and its version.
struct ModelExport {
  model::ModelData model;
  int64_t model_version = 0;
};

// One Session::PlanInputs: the plan, the solver's summary and the model version
// it was planned on.
struct PlanResult {
  plan::Plan plan;
  plan::PlanSummary summary;
  int64_t model_version = 0;
  // Steps after the request's state at which the plan's first input applies (the
  // pending inputs).
  int start_step = 0;
};

// One output's GP as Session::Snapshot reports it.
struct OutputSnapshot {
  gp::Hyperparameters hyperparameters;
  // Absent after a restart until the first refit (the saved hyperparameters are
  // reported, not yet evaluated).
  std::optional<double> log_marginal_likelihood;
  double prior_mean = 0.0;
  // A linear prior mean's slope per kernel input (data units); empty if constant.
  std::vector<double> prior_mean_slopes;
  int inducing_points = 0;  // 0 while the output is an exact GP
  // What the last fit left at a bound (gp::HitBounds); empty for fixed ones.
  std::vector<int> lengthscales_at_bound;
  bool signal_variance_at_bound = false;
};

// What a session reports besides its config and metadata.
struct SessionSnapshot {
  int64_t sample_count = 0;
  int64_t last_sequence = -1;  // -1: no sample yet
  int64_t model_version = 0;
  // Empty before the first fit of a new session (and in a damaged one).
  std::vector<OutputSnapshot> outputs;
  // The latest plan (for the live view); not stored.
  std::optional<PlanResult> last_plan;
};

// Everything a session reports: what GetSession and ListSessions answer.
struct SessionDescription {
  std::string id;
  // The config's stored bytes (SessionSpec::config); in a session set aside
  // because they do not parse, those bytes as stored.
  std::string config;
  std::string display_name;
  std::map<std::string, std::string> labels;
  int64_t created_unix_ms = 0;  // 0: unknown
  SessionSnapshot snapshot;
};

// A session as the store holds it: what ExportSession writes into an archive.
struct StoredSession {
  store::SessionRecord record;
  std::vector<store::SampleRecord> samples;  // in sequence order
};

// One session: its spec, GP dynamics model and planner. It speaks in engine
// types (Eigen, store records, plan summaries, SessionSpec); the API layer
// translates the wire's messages and its status codes.
//
// Thread-safety: all methods are thread-safe. Calls that touch the model
// (AddSamples, Predict, PlanInputs, Export, Delete) are serialised per session;
// different sessions run in parallel. Snapshot() never waits for them: it reads
// a summary refreshed at the end of each call.
//
// Refit is lazy: Predict/PlanInputs (PlanInputs only for the strategies that use
// the model) refit first when the model was never fitted,
// or when kernel.fit is on, refit.never is off and the refit policy's
// gp::RefitSchedule is due (every_samples and growth since the last fit). After a refit
// the hyperparameters are saved in the store (a failure to save is logged, not returned:
// they are a cache). A refit honours the calling RPC's deadline and cancellation: it
// stops with the best hyperparameters found so far, the call fails with DEADLINE_EXCEEDED
// or CANCELLED, and the next call continues the fit from there.
class Session {
 public:
  using Clock = std::chrono::steady_clock;

  // What a person sees of a session besides its config; fixed at creation.
  struct Metadata {
    std::string display_name;
    Labels labels;
    int64_t created_unix_ms = 0;  // 0: unknown
  };

  // A new, empty session. `spec` comes from a validated config and `metadata`
  // was validated by the API layer. `format` (how the saved fit is written) and
  // `store` must outlive the session; its writes carry `fence`, the lease this
  // replica holds on the session (0 in an exclusive store). Does not write the
  // store.
  static absl::StatusOr<std::shared_ptr<Session>> Create(std::string id, SessionSpec spec,
                                                         Metadata metadata,
                                                         const StoredFormat* format,
                                                         store::SessionStore* store,
                                                         int64_t fence = 0);

  // A session rebuilt from the store: its record and all its samples (in any
  // order). The GP gets every sample; it is fitted lazily at first use. With
  // refit.never the saved hyperparameters are reused as fixed ones, so a restart
  // does not change them; otherwise (kernel.fit) they seed the warm start of
  // the first refit and Snapshot() reports them (without a log marginal
  // likelihood) until it ran. model_version resumes at a value no lower than any
  // served before the restart (saved version + sample count). Samples of the
  // wrong shape, or ones the model cannot take (stored by an older version), do
  // not fail the restore: the session is set aside as damaged (logged; AddSamples,
  // Predict and PlanInputs answer DATA_LOSS; Snapshot, Export and Delete work),
  // so one bad session never keeps the server from serving the others.
  // `unreadable` not OK (DATA_LOSS saying which rows the caller could not read
  // from the store), or a stored config that does not parse, also sets the
  // session aside; `samples` are then the rows that could be read.
  // The record's config and fit are read with `format`.
  static absl::StatusOr<std::shared_ptr<Session>> Restore(
      const store::SessionRecord& record, const std::vector<store::SampleRecord>& samples,
      const StoredFormat* format, store::SessionStore* store, int64_t fence = 0,
      absl::Status unreadable = absl::OkStatus());

  // What Describe() of the session restored from `listing` would report before
  // its first call: config, metadata, counts, model version as Restore
  // computes it, and the saved hyperparameters (without log likelihoods).
  static SessionDescription DescribeStored(const store::SessionListing& listing,
                                           const StoredFormat& format);

  // Gives back what the session holds of its memory budget.
  ~Session();
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;

  const std::string& id() const { return id_; }
  // "sessions/{id}".
  const std::string& name() const { return name_; }
  // Dimensions 0 in a session set aside because its config does not parse.
  const SessionSpec& spec() const { return spec_; }
  const Metadata& metadata() const { return metadata_; }
  const Labels& labels() const { return metadata_.labels; }
  int64_t fence() const { return fence_; }

  // A session whose copy here may no longer be the store's: its lease was lost
  // or released, or a write's outcome is unknown (the store was unreachable).
  // Every later call answers UNAVAILABLE; the registry loads the session anew.
  // Set by a failed write, or by MarkStale. Never waits.
  bool stale() const { return stale_.load(std::memory_order_acquire); }
  void MarkStale() { stale_.store(true, std::memory_order_release); }

  // True if no call is running and none ended in the last `duration`. Never
  // waits.
  bool IdleFor(std::chrono::nanoseconds duration) const;
  // Where refit and store-write timings go (nullptr: nowhere, the default). Call
  // before the session is shared; `metrics` must outlive it.
  void AttachMetrics(MetricsSink* metrics) { metrics_ = metrics; }

  // Counts this session's estimated memory in `budget` from now on (nullptr: no
  // budget); the caller has already taken `reserved` bytes of it. AddSamples
  // then takes what more samples need before storing them, Delete gives it all
  // back. Call before the session is shared; `budget` must outlive it.
  void AttachMemoryBudget(MemoryBudget* budget, int64_t reserved);
  // The estimated peak memory of this session holding `samples` samples: the
  // model's (gp::DynamicsModel::PeakBytes) plus the session's own.
  int64_t EstimatedBytes(int64_t samples) const;

  // DATA_LOSS if the session was set aside as damaged at restore (see Restore),
  // else OK. Never waits for a call in progress.
  absl::Status Damage() const;

  // Sample count, last sequence, model version, outputs and the latest plan.
  SessionSnapshot Snapshot() const;
  // The snapshot with the session's id, config and metadata.
  SessionDescription Describe() const;
  // What the session learned since it was loaded (plans, the one-step error of
  // each batch before it was added, the mean predictive std over the region);
  // kept in memory only. Never waits for a call in progress.
  LearningHistory History() const;

  // One batch of measured transitions (shapes and values already validated):
  // checks that the model can take it (INVALID_ARGUMENT "transitions: ...",
  // nothing stored, if not), stores it durably (one transaction), then adds the
  // newly stored samples to the GP. The result counts this batch only. NOT_FOUND
  // if the session was deleted, RESOURCE_EXHAUSTED (nothing stored) if the
  // session would exceed `max_samples` or the memory budget; UNAVAILABLE from
  // a shared store (lease lost, store unreachable) makes the session stale.
  absl::StatusOr<AddResult> AddSamples(const std::vector<store::SampleRecord>& batch,
                                       int64_t max_samples);

  // Mean and latent (+ noise if `include_noise`) variance at each row of `z`
  // (points x (state_dim + input_dim), checked by the caller). FAILED_PRECONDITION
  // before refit.min_samples samples; DEADLINE_EXCEEDED or CANCELLED if a due
  // refit was stopped by min(`refit_deadline`, `deadline`) or `cancelled`, or if
  // `deadline` passed or `cancelled` fired between two chunks of points (each
  // at most 2^21 / n points, which bounds the call's memory).
  absl::StatusOr<Prediction> Predict(const Eigen::MatrixXd& z, bool include_noise,
                                     Clock::time_point refit_deadline,
                                     Clock::time_point deadline,
                                     std::function<bool()> cancelled);

  // The fitted model as a model file holds it (gp::DynamicsModel::ExportModel),
  // after the lazy refit Predict would do (same errors).
  absl::StatusOr<ModelExport> ExportModel(Clock::time_point refit_deadline,
                                          std::function<bool()> cancelled);

  // The state distribution from x_0 ~ N(state, diag(state_variance)) along
  // `inputs` (steps x input_dim; shapes and values checked by the caller),
  // propagated by plan::PropagateLinearised; with `include_noise` each step adds
  // the observation noise (a measured state's distribution). Refits first like
  // Predict (same errors); INTERNAL if the propagation is not finite.
  absl::StatusOr<RolloutResult> Rollout(const Eigen::VectorXd& state,
                                        const Eigen::VectorXd& state_variance,
                                        const Eigen::MatrixXd& inputs, bool include_noise,
                                        Clock::time_point refit_deadline,
                                        std::function<bool()> cancelled);

  // Plans from `state` (state_dim entries, checked by the caller) within
  // `deadline`, polling `cancelled`. DEADLINE_EXCEEDED if the deadline passed
  // before a plan existed, CANCELLED if cancelled, FAILED_PRECONDITION before
  // refit.min_samples samples. The model-free strategies (prbs, chirp, random)
  // neither need data nor refit: they return the next `horizon` samples of their
  // signal, starting at time index = the number of samples the session holds, and
  // no predicted states or variances. The plan's shape is checked (INTERNAL if
  // wrong) and its apply_count clamped to [1, horizon].
  // `pending`: P x input_dim inputs the plant applies from `state` before this
  // plan (checked by the caller; 0 rows for none): the plan starts from the
  // model mean's state after them, and the signals P samples later.
  absl::StatusOr<PlanResult> PlanInputs(const Eigen::VectorXd& state,
                                        const Eigen::MatrixXd& pending,
                                        Clock::time_point deadline,
                                        std::function<bool()> cancelled);

  // The session's record and every sample in sequence order, read from the store
  // (so exactly what a restart would restore) while no other call changes the
  // session; a damaged session gives the rows that can be read. NOT_FOUND if
  // deleted. Cost: O(samples) reads.
  absl::StatusOr<StoredSession> Export();

  // Marks the session deleted (later calls on it return NOT_FOUND) and removes it
  // and its samples from the store. NOT_FOUND if already deleted.
  absl::Status Delete();

 private:
  Session(std::string id, SessionSpec spec, Metadata metadata,
          std::optional<gp::DynamicsModel> model, const StoredFormat* format,
          store::SessionStore* store, int64_t fence);
  // Counts one call from construction to destruction (IdleFor).
  class CallScope {
   public:
    explicit CallScope(Session* session);
    ~CallScope();
    CallScope(const CallScope&) = delete;
    CallScope& operator=(const CallScope&) = delete;

   private:
    Session* const session_;
  };
  static Metadata MetadataOf(const store::SessionRecord& record);
  // A damaged session (see Restore): no model, every model call answers `damage`
  // as DATA_LOSS.
  static std::shared_ptr<Session> SetAside(
      const store::SessionRecord& record, SessionSpec spec,
      const std::vector<store::SampleRecord>& samples, absl::Status damage,
      const StoredFormat* format, store::SessionStore* store, int64_t fence);
  // A store write's failure as the caller gets it; UNAVAILABLE from a shared
  // store (the lease lost, or an outcome unknown) also makes the session stale.
  absl::Status StoreWriteFailed(const absl::Status& status, absl::string_view what);

  // NOT_FOUND once deleted, UNAVAILABLE once stale, DATA_LOSS if damaged.
  absl::Status CheckUsable() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  absl::Status StaleError() const;
  // INVALID_ARGUMENT unless the model can add `batch` (GP DynamicsModel::
  // CheckSamples): checked before anything is stored, so that no stored sample
  // can leave a model that cannot answer.
  absl::Status CheckModelAccepts(const TransitionRows& rows)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // FAILED_PRECONDITION before min_samples, then the lazy refit, stopped early
  // (DEADLINE_EXCEEDED / CANCELLED) by `deadline` or `cancelled`. Waits for a
  // plan or fit under way; releases mu_ while it fits.
  absl::Status EnsureFitted(Clock::time_point deadline,
                            const std::function<bool()>& cancelled)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // What a read (Predict, Rollout, ExportModel) needs: during a plan or fit, the
  // model as it is if fitted (the read answers from that version, no refit);
  // otherwise EnsureFitted.
  absl::Status EnsureReadable(Clock::time_point deadline,
                              const std::function<bool()>& cancelled)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // Adds stored rows to the GP as the next model version; INTERNAL if the GP
  // update failed (the samples stay stored, and the next refit rebuilds it).
  absl::Status AddToModel(const TransitionRows& rows) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // Adds deferred_ once a plan or fit has ended (a failure is logged: the samples
  // were acknowledged to their caller already).
  void ApplyDeferred() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // INTERNAL unless `plan` has the shape of this session's plans.
  absl::Status CheckPlanShape(const plan::Plan& plan, bool model_free) const;
  void PublishSnapshot() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // Gives back what AddSamples reserved beyond EstimatedBytes(sample_count_).
  void SettleBudget() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // History: the batch's one-step error by the model as it is (before the batch
  // is added), and the mean predictive std once due. Only for a fitted model;
  // a failure is logged, never the call's.
  void RecordBatchError(const TransitionRows& rows) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  void RecordUncertaintyIfDue() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);

  const std::string id_;
  const std::string name_;
  const SessionSpec spec_;
  const Metadata metadata_;
  const StoredFormat* const format_;
  store::SessionStore* const store_;
  const int64_t fence_;
  MetricsSink* metrics_ = nullptr;
  MemoryBudget* budget_ = nullptr;

  // Held by PlanInputs for the whole plan: one plan of a session at a time (a
  // second waits). The plan itself runs without mu_, on the model as it was when
  // the plan started (model_in_use_), so that reads and AddData do not wait.
  absl::Mutex plan_mu_ ABSL_ACQUIRED_BEFORE(mu_);
  plan::Planner planner_ ABSL_GUARDED_BY(plan_mu_);
  absl::Mutex mu_;
  // Empty only in a damaged session. While model_in_use_, a plan reads it, or a
  // fit works on a copy of its data, without mu_: nothing changes it then
  // (AddSamples defers, reads use it as it is, another fit waits).
  std::optional<gp::DynamicsModel> model_ ABSL_GUARDED_BY(mu_);
  bool model_in_use_ ABSL_GUARDED_BY(mu_) = false;
  // Stored and acknowledged during a plan or fit; added to the model after it.
  std::vector<TransitionRows> deferred_ ABSL_GUARDED_BY(mu_);
  int64_t sample_count_ ABSL_GUARDED_BY(mu_) = 0;
  int64_t last_sequence_ ABSL_GUARDED_BY(mu_) = -1;
  int64_t model_version_ ABSL_GUARDED_BY(mu_) = 0;
  bool deleted_ ABSL_GUARDED_BY(mu_) = false;
  // Snapshot() reports it (for the live view); not stored.
  std::optional<PlanResult> last_plan_ ABSL_GUARDED_BY(mu_);
  // Where the last plan started (samples held + its pending inputs) and whether
  // it had pending inputs: a plant that runs ahead of the plans tells the
  // planner how far to shift its warm start.
  int64_t last_plan_start_ ABSL_GUARDED_BY(mu_) = 0;
  bool last_plan_pending_ ABSL_GUARDED_BY(mu_) = false;
  // Bytes of budget_ this session holds: EstimatedBytes(sample_count_).
  int64_t reserved_bytes_ ABSL_GUARDED_BY(mu_) = 0;
  // DATA_LOSS if restored from samples the model cannot use: every call but
  // Snapshot, Export and Delete returns it.
  absl::Status damaged_ ABSL_GUARDED_BY(mu_);

  // The region's reference set for the history's mean predictive std: a Halton
  // set over state_bounds x input_bounds; empty without state bounds.
  const Eigen::MatrixXd uncertainty_reference_;

  std::atomic<bool> stale_{false};
  std::atomic<int> calls_{0};
  // steady_clock nanoseconds at the end of the last call.
  std::atomic<int64_t> last_call_end_ns_{0};

  mutable absl::Mutex snapshot_mu_ ABSL_ACQUIRED_AFTER(mu_);
  SessionSnapshot snapshot_ ABSL_GUARDED_BY(snapshot_mu_);
  absl::Status damage_ ABSL_GUARDED_BY(snapshot_mu_);  // damaged_, readable without mu_
  LearningHistory history_ ABSL_GUARDED_BY(snapshot_mu_);
};

}  // namespace excite::session

#endif  // EXCITE_SERVER_SESSION_SESSION_H_
