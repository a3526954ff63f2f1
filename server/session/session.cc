#include "server/session/session.h"

#include <algorithm>
#include <exception>
#include <functional>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "common/logging.h"
#include "server/plan/plan_slots.h"
#include "server/plan/reference_set.h"
#include "server/plan/rollout.h"
#include "server/session/memory_budget.h"
#include "server/session/session_name.h"

namespace excite::session {
namespace {

// Entries of one Predict chunk's cross-covariance matrix (points x samples):
// 2^21 doubles, 16 MiB.
constexpr Eigen::Index kPredictChunkEntries = Eigen::Index{1} << 21;

// What a session holds besides its model (config, planner, strategy state,
// summary): an empty one takes 3.1 KiB (bench/load/session_memory.py); planning
// adds its workspace, which grows with the horizon.
constexpr int64_t kSessionBytes = int64_t{32} << 10;

// Points of the history's reference set: the mean std of 128 points is within
// a few percent of the region's average (Halton), at O(128 n^2) per record.
constexpr int kUncertaintyReferencePoints = 128;

// The uncertainty reference set of `spec`: empty unless it has state bounds.
Eigen::MatrixXd UncertaintyReference(const SessionSpec& spec) {
  const plan::PlanOptions& plan = spec.plan;
  if (plan.state_lower.size() != spec.state_dim ||
      plan.input_lower.size() != spec.input_dim) {
    return {};
  }
  Eigen::VectorXd lower(spec.state_dim + spec.input_dim);
  Eigen::VectorXd upper(lower.size());
  lower << plan.state_lower, plan.input_lower;
  upper << plan.state_upper, plan.input_upper;
  return plan::HaltonReferenceSet(lower, upper, kUncertaintyReferencePoints, plan.seed);
}

// The samples, which must have state_dim `dx` and input_dim `du`, as rows.
TransitionRows ToRows(const std::vector<store::SampleRecord>& samples, int dx, int du) {
  const auto n = static_cast<Eigen::Index>(samples.size());
  TransitionRows rows{Eigen::MatrixXd(n, dx), Eigen::MatrixXd(n, du),
                      Eigen::MatrixXd(n, dx)};
  for (Eigen::Index i = 0; i < n; ++i) {
    const store::SampleRecord& s = samples[static_cast<size_t>(i)];
    rows.states.row(i) = Eigen::Map<const Eigen::RowVectorXd>(s.state.data(), dx);
    rows.inputs.row(i) = Eigen::Map<const Eigen::RowVectorXd>(s.input.data(), du);
    rows.next_states.row(i) =
        Eigen::Map<const Eigen::RowVectorXd>(s.next_state.data(), dx);
  }
  return rows;
}

// The rows for which `keep` is true (Eigen 3.4's index-list slicing).
TransitionRows Kept(const TransitionRows& rows, const std::vector<bool>& keep) {
  std::vector<Eigen::Index> kept;
  for (size_t i = 0; i < keep.size(); ++i) {
    if (keep[i]) kept.push_back(static_cast<Eigen::Index>(i));
  }
  return {rows.states(kept, Eigen::all), rows.inputs(kept, Eigen::all),
          rows.next_states(kept, Eigen::all)};
}

double SecondsSince(Session::Clock::time_point start) {
  return std::chrono::duration<double>(Session::Clock::now() - start).count();
}

absl::Status NotDeleted(const std::string& name) {
  return absl::NotFoundError(absl::StrCat("session ", name, " not found"));
}

// Engine calls must not let an exception escape the service.
absl::Status InternalFromException(absl::string_view what, const std::exception& e) {
  return absl::InternalError(absl::StrCat(what, ": unexpected exception: ", e.what()));
}

// absl::Condition's test of Session::model_in_use_.
bool NotInUse(bool* in_use) { return !*in_use; }

// Where a plan starts: `state`, or the model mean's state after the `pending`
// inputs (INTERNAL if that is not finite).
absl::StatusOr<Eigen::VectorXd> StateAfter(const gp::DynamicsModel& model,
                                           const Eigen::VectorXd& state,
                                           const Eigen::MatrixXd& pending,
                                           const std::string& name) {
  if (pending.rows() == 0) return state;
  const plan::Rollout ahead = plan::RollOut(model, state, pending);
  if (!ahead.valid) {
    return absl::InternalError(absl::StrCat(
        "session ", name, ": the model's prediction along pending_inputs is not finite"));
  }
  return Eigen::VectorXd(ahead.means.row(ahead.means.rows() - 1).transpose());
}

// A refit uses the process's free planner workers: one fit thread per planner slot,
// at least two (the caller's and one more, as before) and at most four (the GP's
// copies of LAPACK, blas/lapack_copies.h); threads beyond two fit only while a slot
// is free, holding it.
constexpr int kMaxFitThreads = 4;
int FitThreads() { return std::clamp(plan::ConcurrentPlans(), 2, kMaxFitThreads); }

gp::DynamicsModelOptions WithFitWorkers(gp::DynamicsModelOptions options) {
  options.fit_threads = FitThreads();
  options.run_if_worker_free = [](const std::function<void()>& work) {
    plan::PlanSlot slot;
    if (slot.TryAcquire()) work();
  };
  return options;
}

}  // namespace

Session::Session(std::string id, SessionSpec spec, Metadata metadata,
                 std::optional<gp::DynamicsModel> model, const StoredFormat* format,
                 store::SessionStore* store, int64_t fence)
    : id_(std::move(id)),
      name_(SessionName(id_)),
      spec_(std::move(spec)),
      metadata_(std::move(metadata)),
      format_(format),
      store_(store),
      fence_(fence),
      planner_(spec_.plan),
      model_(std::move(model)),
      uncertainty_reference_(UncertaintyReference(spec_)) {}

Session::~Session() {
  absl::MutexLock lock(&mu_);
  if (budget_ != nullptr) budget_->Release(reserved_bytes_);
}

Session::CallScope::CallScope(Session* session) : session_(session) {
  session_->calls_.fetch_add(1, std::memory_order_acq_rel);
}

Session::CallScope::~CallScope() {
  session_->last_call_end_ns_.store(Clock::now().time_since_epoch().count(),
                                    std::memory_order_release);
  session_->calls_.fetch_sub(1, std::memory_order_acq_rel);
}

bool Session::IdleFor(std::chrono::nanoseconds duration) const {
  if (calls_.load(std::memory_order_acquire) > 0) return false;
  const Clock::time_point last_end(
      Clock::duration(last_call_end_ns_.load(std::memory_order_acquire)));
  return Clock::now() - last_end >= duration;
}

absl::Status Session::StoreWriteFailed(const absl::Status& status,
                                       absl::string_view what) {
  if (absl::IsNotFound(status)) return NotDeleted(name_);
  // A shared store: the lease was lost or the write's outcome is unknown, so
  // this copy can no longer be trusted to match the store (the registry loads it
  // anew). SQLite's failed writes are rolled back: the copy stays right.
  if (absl::IsUnavailable(status) && store_->shared()) MarkStale();
  return absl::Status(status.code(),
                      absl::StrCat(what, " of session ", name_, ": ", status.message()));
}

Session::Metadata Session::MetadataOf(const store::SessionRecord& record) {
  return {record.display_name, record.labels, record.created_unix_ms};
}

absl::StatusOr<std::shared_ptr<Session>> Session::Create(std::string id, SessionSpec spec,
                                                         Metadata metadata,
                                                         const StoredFormat* format,
                                                         store::SessionStore* store,
                                                         int64_t fence) {
  try {
    absl::StatusOr<gp::DynamicsModel> model =
        gp::DynamicsModel::Create(WithFitWorkers(spec.model));
    if (!model.ok()) {
      return absl::Status(model.status().code(),
                          absl::StrCat("config: ", model.status().message()));
    }
    std::shared_ptr<Session> session(new Session(std::move(id), std::move(spec),
                                                 std::move(metadata), *std::move(model),
                                                 format, store, fence));
    absl::MutexLock lock(&session->mu_);
    session->PublishSnapshot();
    return session;
  } catch (const std::exception& e) {
    return InternalFromException("creating the session's model", e);
  }
}

absl::StatusOr<std::shared_ptr<Session>> Session::Restore(
    const store::SessionRecord& record, const std::vector<store::SampleRecord>& samples,
    const StoredFormat* format, store::SessionStore* store, int64_t fence,
    absl::Status unreadable) {
  absl::StatusOr<SessionSpec> decoded = format->DecodeConfig(record.config);
  if (!decoded.ok()) {
    SessionSpec unknown;
    unknown.config = record.config;
    return SetAside(record, std::move(unknown), samples,
                    absl::DataLossError("its stored config does not parse"), format,
                    store, fence);
  }
  SessionSpec config = *std::move(decoded);
  if (!unreadable.ok()) {
    return SetAside(record, std::move(config), samples, std::move(unreadable), format,
                    store, fence);
  }
  try {
    gp::DynamicsModelOptions options = config.model;
    if (config.refit.never && config.refit.fit_kernel) {
      if (std::optional<SavedFit> saved = format->DecodeFit(
              record.hyperparameters, config.state_dim, config.kernel_inputs())) {
        options.fit_kernel = false;
        options.fit_noise = false;
        options.fixed = std::move(saved->hyperparameters);
      }
    }
    const bool options_fit_kernel = options.fit_kernel;
    absl::StatusOr<gp::DynamicsModel> model =
        gp::DynamicsModel::Create(WithFitWorkers(std::move(options)));
    if (!model.ok()) {
      return absl::Status(model.status().code(), absl::StrCat("session ", record.id, ": ",
                                                              model.status().message()));
    }
    const int dx = config.state_dim;
    const int du = config.input_dim;
    const Eigen::Index n = static_cast<Eigen::Index>(samples.size());
    int64_t last_sequence = -1;
    absl::Status damaged;
    for (const store::SampleRecord& s : samples) {
      last_sequence = std::max(last_sequence, s.sequence);
      if (damaged.ok() && (static_cast<int>(s.state.size()) != dx ||
                           static_cast<int>(s.input.size()) != du ||
                           static_cast<int>(s.next_state.size()) != dx)) {
        damaged = absl::DataLossError(
            absl::StrCat("stored sample ", s.sequence, " has the wrong shape"));
      }
    }
    if (n > 0 && damaged.ok()) {
      // Samples stored by an older version may be ones the model cannot take
      // (e.g. 1e308, before value_ranges.h).
      const TransitionRows rows = ToRows(samples, dx, du);
      if (absl::Status s = model->AddSamples(rows.states, rows.inputs, rows.next_states);
          !s.ok()) {
        damaged = absl::DataLossError(absl::StrCat(
            "its stored samples cannot be used by the model: ", s.message()));
      }
    }
    if (!damaged.ok()) {
      return SetAside(record, std::move(config), samples, std::move(damaged), format,
                      store, fence);
    }
    if (options_fit_kernel) {
      // The model is rebuilt with the last saved fit while it is current, and
      // the next refit starts from it (a cache: unusable bytes just mean a cold
      // start).
      if (std::optional<SavedFit> saved = format->DecodeFit(
              record.hyperparameters, config.state_dim, config.kernel_inputs())) {
        const int fitted = static_cast<int>(std::min<int64_t>(saved->fitted_samples, n));
        if (absl::Status s =
                model->SeedWarmStart(std::move(saved->hyperparameters), fitted);
            !s.ok()) {
          Log(LogLevel::kWarning,
              absl::StrCat("session ", record.id,
                           ": saved hyperparameters not used: ", s.message()));
        }
      }
    }
    std::shared_ptr<Session> session(new Session(record.id, std::move(config),
                                                 MetadataOf(record), *std::move(model),
                                                 format, store, fence));
    absl::MutexLock lock(&session->mu_);
    session->sample_count_ = n;
    session->last_sequence_ = last_sequence;
    session->model_version_ = record.model_version + n;
    session->PublishSnapshot();
    return session;
  } catch (const std::exception& e) {
    return InternalFromException(absl::StrCat("restoring session ", record.id), e);
  }
}

std::shared_ptr<Session> Session::SetAside(
    const store::SessionRecord& record, SessionSpec spec,
    const std::vector<store::SampleRecord>& samples, absl::Status damage,
    const StoredFormat* format, store::SessionStore* store, int64_t fence) {
  // Not fatal: the server serves every other session.
  absl::Status damaged = absl::DataLossError(absl::StrCat(
      "session ", SessionName(record.id), " is damaged: ", damage.message(),
      "; its data is kept: ExportSession reads what is readable, DeleteSession "
      "removes it"));
  Log(LogLevel::kError, std::string(damaged.message()));
  int64_t last_sequence = -1;
  for (const store::SampleRecord& s : samples) {
    last_sequence = std::max(last_sequence, s.sequence);
  }
  const auto n = static_cast<int64_t>(samples.size());
  std::shared_ptr<Session> session(new Session(record.id, std::move(spec),
                                               MetadataOf(record), std::nullopt, format,
                                               store, fence));
  absl::MutexLock lock(&session->mu_);
  session->damaged_ = std::move(damaged);
  session->sample_count_ = n;
  session->last_sequence_ = last_sequence;
  session->model_version_ = record.model_version + n;
  session->PublishSnapshot();
  return session;
}

SessionSnapshot Session::Snapshot() const {
  absl::MutexLock lock(&snapshot_mu_);
  return snapshot_;
}

SessionDescription Session::Describe() const {
  SessionDescription description;
  description.id = id_;
  description.config = spec_.config;
  description.display_name = metadata_.display_name;
  description.labels = metadata_.labels;
  description.created_unix_ms = metadata_.created_unix_ms;
  description.snapshot = Snapshot();
  return description;
}

SessionDescription Session::DescribeStored(const store::SessionListing& listing,
                                           const StoredFormat& format) {
  const store::SessionRecord& record = listing.record;
  SessionDescription description;
  description.id = record.id;
  description.config = record.config;
  description.display_name = record.display_name;
  description.labels = record.labels;
  description.created_unix_ms = record.created_unix_ms;
  SessionSnapshot& snapshot = description.snapshot;
  snapshot.sample_count = listing.sample_count;
  snapshot.last_sequence = listing.last_sequence;
  snapshot.model_version = record.model_version + listing.sample_count;
  absl::StatusOr<SessionSpec> spec = format.DecodeConfig(record.config);
  std::optional<SavedFit> saved;
  if (spec.ok()) {
    saved =
        format.DecodeFit(record.hyperparameters, spec->state_dim, spec->kernel_inputs());
  }
  if (saved.has_value()) {
    for (gp::Hyperparameters& h : saved->hyperparameters) {
      OutputSnapshot output;
      output.hyperparameters = std::move(h);
      snapshot.outputs.push_back(std::move(output));
    }
  }
  return description;
}

LearningHistory Session::History() const {
  absl::MutexLock lock(&snapshot_mu_);
  return history_;
}

void Session::RecordBatchError(const TransitionRows& rows) {
  if (!model_->fitted() || rows.states.rows() == 0) return;
  BatchError record;
  record.sample_count = sample_count_;
  record.batch_size = rows.states.rows();
  record.model_version = model_version_;
  try {
    record.rmse = OneStepRmse(*model_, rows.states, rows.inputs, rows.next_states,
                              spec_.model.angle_dims);
  } catch (const std::exception& e) {
    Log(LogLevel::kWarning,
        InternalFromException(absl::StrCat("the one-step error of ", name_), e)
            .ToString());
    return;
  }
  if (!record.rmse.allFinite()) return;
  absl::MutexLock lock(&snapshot_mu_);
  history_.Add(std::move(record));
}

void Session::RecordUncertaintyIfDue() {
  if (uncertainty_reference_.rows() == 0 || !model_->fitted()) return;
  {
    absl::MutexLock lock(&snapshot_mu_);
    if (!history_.UncertaintyDue(sample_count_)) return;
  }
  UncertaintyRecord record;
  record.sample_count = sample_count_;
  record.model_version = model_version_;
  try {
    record.mean_std = MeanPredictiveStd(*model_, uncertainty_reference_);
  } catch (const std::exception& e) {
    Log(LogLevel::kWarning,
        InternalFromException(absl::StrCat("the mean std of ", name_), e).ToString());
    return;
  }
  if (!record.mean_std.allFinite()) return;
  absl::MutexLock lock(&snapshot_mu_);
  history_.Add(std::move(record));
}

absl::Status Session::Damage() const {
  absl::MutexLock lock(&snapshot_mu_);
  return damage_;
}

void Session::PublishSnapshot() {
  SessionSnapshot snapshot;
  snapshot.last_plan = last_plan_;
  snapshot.sample_count = sample_count_;
  snapshot.last_sequence = last_sequence_;
  snapshot.model_version = model_version_;
  // After a restart and before the first refit: the saved hyperparameters (the
  // warm start of that refit), without a log marginal likelihood.
  if (model_.has_value()) {
    std::vector<gp::Hyperparameters> hyperparameters = model_->hyperparameters();
    const std::vector<double> lml = model_->log_marginal_likelihoods();
    const std::vector<int> inducing = model_->inducing_counts();
    const Eigen::VectorXd prior_means = model_->prior_means();
    const Eigen::MatrixXd slopes = model_->prior_mean_slopes();
    const std::vector<gp::BoundHits> hits = model_->bound_hits();
    for (size_t i = 0; i < hyperparameters.size(); ++i) {
      OutputSnapshot output;
      output.hyperparameters = std::move(hyperparameters[i]);
      if (i < lml.size()) output.log_marginal_likelihood = lml[i];
      output.prior_mean = prior_means(static_cast<Eigen::Index>(i));
      if (static_cast<Eigen::Index>(i) < slopes.rows()) {
        const Eigen::VectorXd row = slopes.row(static_cast<Eigen::Index>(i));
        output.prior_mean_slopes.assign(row.begin(), row.end());
      }
      if (i < inducing.size()) output.inducing_points = inducing[i];
      if (i < hits.size()) {
        output.lengthscales_at_bound = hits[i].lengthscales;
        output.signal_variance_at_bound = hits[i].signal_variance;
      }
      snapshot.outputs.push_back(std::move(output));
    }
  }
  absl::MutexLock lock(&snapshot_mu_);
  snapshot_ = std::move(snapshot);
  damage_ = damaged_;
}

absl::Status Session::StaleError() const {
  return absl::UnavailableError(
      absl::StrCat("session ", name_,
                   " is being moved or reloaded on this replica (its lease ended, or "
                   "the store was unreachable during a write): retry"));
}

absl::Status Session::CheckUsable() {
  if (deleted_) return NotDeleted(name_);
  if (stale()) return StaleError();
  return damaged_;
}

absl::Status Session::CheckModelAccepts(const TransitionRows& rows) {
  absl::Status checked = model_->CheckSamples(rows.states, rows.inputs, rows.next_states);
  if (checked.ok()) return checked;
  return absl::InvalidArgumentError(
      absl::StrCat("transitions: the model of session ", name_,
                   " cannot take them (nothing was stored): ", checked.message()));
}

absl::StatusOr<AddResult> Session::AddSamples(
    const std::vector<store::SampleRecord>& batch, int64_t max_samples) {
  const CallScope call(this);
  const int dx = spec_.state_dim;
  const int du = spec_.input_dim;
  absl::MutexLock lock(&mu_);
  if (absl::Status s = CheckUsable(); !s.ok()) return s;
  AddResult result;
  if (!batch.empty()) {
    if (sample_count_ + static_cast<int64_t>(batch.size()) > max_samples) {
      return absl::ResourceExhaustedError(absl::StrCat(
          "session ", name_, " has ", sample_count_, " samples; ", batch.size(),
          " more would exceed the cap of ", max_samples, " per session"));
    }
    // Converted once: checked before storing, the stored ones added after.
    TransitionRows rows = ToRows(batch, dx, du);
    if (absl::Status s = CheckModelAccepts(rows); !s.ok()) return s;
    const int64_t after = sample_count_ + static_cast<int64_t>(batch.size());
    if (budget_ != nullptr) {
      // Taken before storing (nothing is stored if it does not fit), settled to
      // what was actually stored below.
      const int64_t needed = EstimatedBytes(after);
      if (absl::Status s =
              budget_->Reserve(needed - reserved_bytes_,
                               absl::StrCat("session ", name_, " with ", after,
                                            " samples (", batch.size(), " more)"));
          !s.ok()) {
        return s;
      }
      reserved_bytes_ = needed;
    }
    const Clock::time_point write_start = Clock::now();
    absl::StatusOr<store::InsertResult> inserted =
        store_->InsertSamples(id_, fence_, batch);
    if (metrics_ != nullptr && inserted.ok()) {
      metrics_->RecordStoreWrite("insert_samples", SecondsSince(write_start));
    }
    if (!inserted.ok()) {
      SettleBudget();
      return StoreWriteFailed(inserted.status(), "storing the samples");
    }
    const Eigen::Index n = inserted->stored_count;
    if (n > 0) {
      for (size_t i = 0; i < batch.size(); ++i) {
        if (inserted->stored[i])
          last_sequence_ = std::max(last_sequence_, batch[i].sequence);
      }
      if (n < static_cast<Eigen::Index>(batch.size())) {
        rows = Kept(rows, inserted->stored);  // duplicates are not added again
      }
      RecordBatchError(rows);
      // The samples are stored whatever happens below; count them so that the
      // session agrees with the store (and with itself after a restart).
      sample_count_ += n;
      SettleBudget();
      if (model_in_use_) {
        // A plan reads the model now: they enter it when the plan ends.
        deferred_.push_back(std::move(rows));
      } else if (absl::Status added = AddToModel(rows); !added.ok()) {
        PublishSnapshot();
        return added;
      }
    }
    result.stored = inserted->stored_count;
    result.duplicates = inserted->duplicate_count;
    SettleBudget();  // all duplicates: nothing added
  }
  result.sample_count = sample_count_;
  result.model_version = model_version_;
  PublishSnapshot();
  return result;
}

absl::Status Session::AddToModel(const TransitionRows& rows) {
  absl::Status added;
  try {
    added = model_->AddSamples(rows.states, rows.inputs, rows.next_states);
  } catch (const std::exception& e) {
    added = InternalFromException("adding samples to the GP", e);
  }
  ++model_version_;
  if (!added.ok()) {
    return absl::InternalError(absl::StrCat("session ", name_, ": ", rows.states.rows(),
                                            " samples were stored but the GP update "
                                            "failed: ",
                                            added.message()));
  }
  RecordUncertaintyIfDue();
  return added;
}

void Session::ApplyDeferred() {
  for (const TransitionRows& rows : deferred_) {
    if (absl::Status s = AddToModel(rows); !s.ok()) {
      Log(LogLevel::kWarning, absl::StrCat(s.message(),
                                           " (after a plan; the next refit "
                                           "rebuilds the GP from them)"));
    }
  }
  if (!deferred_.empty()) PublishSnapshot();
  deferred_.clear();
}

absl::Status Session::EnsureReadable(Clock::time_point deadline,
                                     const std::function<bool()>& cancelled) {
  if (model_in_use_ && model_->fitted()) return absl::OkStatus();
  return EnsureFitted(deadline, cancelled);
}

absl::Status Session::EnsureFitted(Clock::time_point deadline,
                                   const std::function<bool()>& cancelled) {
  // After any plan or fit under way (and its deferred samples): the model then
  // holds every stored sample.
  mu_.Await(absl::Condition(&NotInUse, &model_in_use_));
  const int64_t min_samples = spec_.refit.min_samples;
  if (sample_count_ < min_samples) {
    return absl::FailedPreconditionError(absl::StrCat(
        "session ", name_, " has ", sample_count_, " samples; at least ", min_samples,
        " are needed before Predict/PlanInputs: stream data with AddData first"));
  }
  const bool refit_due =
      spec_.refit.refits() && gp::RefitDue(spec_.refit.schedule, model_->sample_count(),
                                           model_->samples_since_fit());
  if (model_->fitted() && !refit_due) return absl::OkStatus();
  // Restored with a fit that is still current: rebuilt to predict as before the
  // restart. Otherwise refitted.
  const bool rebuild =
      !refit_due && spec_.refit.refits() && !model_->hyperparameters().empty();
  const gp::FitStopFn stop = [&]() {
    return Clock::now() >= deadline || (cancelled && cancelled());
  };
  // The fit runs on a copy of the data without mu_: meanwhile reads answer from
  // the model as it is and AddData defers, and a failed fit leaves it in place.
  gp::DynamicsModel next = model_->CopyData();
  model_in_use_ = true;
  mu_.Unlock();
  absl::StatusOr<gp::FitSummary> summary;
  try {
    if (rebuild) {
      const absl::Status rebuilt = next.Rebuild();
      summary = rebuilt.ok() ? absl::StatusOr<gp::FitSummary>(gp::FitSummary{}) : rebuilt;
    } else {
      summary = next.Refit(stop);
    }
  } catch (const std::exception& e) {
    summary = InternalFromException(rebuild ? "rebuild" : "refit", e);
  }
  ReturnFreedMemory();  // the factorisation's n x n temporaries
  mu_.Lock();
  model_in_use_ = false;
  if (summary.ok()) *model_ = std::move(next);
  ApplyDeferred();
  if (!summary.ok()) {
    return absl::InternalError(
        absl::StrCat(rebuild ? "rebuilding" : "refit of", " session ", name_, " with ",
                     sample_count_, " samples failed: ", summary.status().message()));
  }
  if (rebuild) {
    PublishSnapshot();
    return absl::OkStatus();
  }
  ++model_version_;
  PublishSnapshot();
  RecordUncertaintyIfDue();
  if (metrics_ != nullptr) {
    metrics_->RecordFit(summary->wall_time_ms / 1000.0, summary->stopped);
  }
  if (LogEnabled(LogLevel::kDebug)) {
    Log(LogLevel::kDebug,
        absl::StrCat("refit ", name_, " n=", sample_count_, " starts=", summary->starts,
                     " iterations=", summary->iterations,
                     " failed_starts=", summary->failed_starts,
                     " ms=", summary->wall_time_ms, summary->stopped ? " stopped" : ""));
  }
  const std::string saved = format_->EncodeFit(
      {model_->hyperparameters(), sample_count_ - model_->samples_since_fit()});
  const Clock::time_point write_start = Clock::now();
  if (absl::Status s = store_->SaveModelState(id_, fence_, saved, model_version_);
      !s.ok()) {
    // Not the call's failure (they are a cache), but a lost lease still makes
    // this copy stale.
    Log(LogLevel::kWarning, StoreWriteFailed(s, "saving the hyperparameters").ToString());
  } else if (metrics_ != nullptr) {
    metrics_->RecordStoreWrite("save_model", SecondsSince(write_start));
  }
  if (!summary->stopped) return absl::OkStatus();
  // The best hyperparameters so far are in place and saved; the next call
  // continues the fit.
  if (cancelled && cancelled()) {
    return absl::CancelledError(
        absl::StrCat("the refit of session ", name_, " was cancelled by the client"));
  }
  return absl::DeadlineExceededError(absl::StrCat(
      "the deadline passed during the refit of session ", name_, " (", sample_count_,
      " samples, ", static_cast<int64_t>(summary->wall_time_ms),
      " ms); the best hyperparameters so far are kept and the next call continues "
      "the fit: retry with a longer deadline"));
}

absl::StatusOr<Prediction> Session::Predict(const Eigen::MatrixXd& z, bool include_noise,
                                            Clock::time_point refit_deadline,
                                            Clock::time_point deadline,
                                            std::function<bool()> cancelled) {
  const CallScope call(this);
  absl::MutexLock lock(&mu_);
  if (absl::Status s = CheckUsable(); !s.ok()) return s;
  if (absl::Status s = EnsureReadable(std::min(refit_deadline, deadline), cancelled);
      !s.ok()) {
    return s;
  }
  const int dx = spec_.state_dim;
  const Eigen::Index m = z.rows();
  // Chunks of at most kPredictChunkEntries / n points: the cross-covariances of
  // one chunk (chunk x n per output) bound the call's memory, whatever m is.
  const Eigen::Index chunk = std::max<Eigen::Index>(
      1, kPredictChunkEntries / std::max<Eigen::Index>(1, sample_count_));
  Prediction prediction;
  prediction.mean.resize(m, dx);
  prediction.variance.resize(m, dx);
  const Eigen::VectorXd noise =
      include_noise ? model_->noise_variances() : Eigen::VectorXd();
  try {
    for (Eigen::Index first = 0; first < m; first += chunk) {
      if (first > 0 && (Clock::now() >= deadline || (cancelled && cancelled()))) {
        if (cancelled && cancelled()) {
          return absl::CancelledError("Predict was cancelled by the client");
        }
        return absl::DeadlineExceededError(absl::StrCat(
            "Predict on ", name_, ": the deadline passed after ", first, " of ", m,
            " points; ask for fewer points per call or allow more time"));
      }
      const Eigen::Index rows = std::min(chunk, m - first);
      Eigen::MatrixXd mean;
      Eigen::MatrixXd variance;
      model_->Predict(z.middleRows(first, rows), &mean, &variance, nullptr, nullptr);
      if (mean.rows() != rows || mean.cols() != dx || variance.rows() != rows ||
          variance.cols() != dx) {
        return absl::InternalError(absl::StrCat(
            "session ", name_, ": the model returned a prediction of the wrong shape"));
      }
      if (noise.size() == dx) variance.rowwise() += noise.transpose();
      if (!mean.allFinite() || !variance.allFinite()) {
        return absl::InternalError(
            absl::StrCat("session ", name_, ": the model predicted non-finite numbers"));
      }
      prediction.mean.middleRows(first, rows) = mean;
      prediction.variance.middleRows(first, rows) = variance;
    }
  } catch (const std::exception& e) {
    return InternalFromException(absl::StrCat("Predict on ", name_), e);
  }
  prediction.model_version = model_version_;
  return prediction;
}

absl::StatusOr<RolloutResult> Session::Rollout(const Eigen::VectorXd& state,
                                               const Eigen::VectorXd& state_variance,
                                               const Eigen::MatrixXd& inputs,
                                               bool include_noise,
                                               Clock::time_point refit_deadline,
                                               std::function<bool()> cancelled) {
  const CallScope call(this);
  absl::MutexLock lock(&mu_);
  if (absl::Status s = CheckUsable(); !s.ok()) return s;
  if (absl::Status s = EnsureReadable(refit_deadline, cancelled); !s.ok()) return s;
  RolloutResult result;
  try {
    result.trajectory = plan::PropagateLinearised(
        *model_, state, state_variance.asDiagonal().toDenseMatrix(), inputs,
        include_noise ? model_->noise_variances() : Eigen::VectorXd());
  } catch (const std::exception& e) {
    return InternalFromException(absl::StrCat("Rollout on ", name_), e);
  }
  if (!result.trajectory.valid) {
    return absl::InternalError(absl::StrCat(
        "session ", name_, ": the rollout's mean or covariance is not finite"));
  }
  result.model_version = model_version_;
  return result;
}

absl::StatusOr<ModelExport> Session::ExportModel(Clock::time_point refit_deadline,
                                                 std::function<bool()> cancelled) {
  const CallScope call(this);
  absl::MutexLock lock(&mu_);
  if (absl::Status s = CheckUsable(); !s.ok()) return s;
  if (absl::Status s = EnsureReadable(refit_deadline, cancelled); !s.ok()) return s;
  std::optional<model::ModelData> data = model_->ExportModel();
  if (!data.has_value()) {
    return absl::InternalError(
        absl::StrCat("session ", name_, ": the model is not fitted after its refit"));
  }
  data->model_version = model_version_;
  return ModelExport{*std::move(data), model_version_};
}

absl::Status Session::CheckPlanShape(const plan::Plan& plan, bool model_free) const {
  const Eigen::Index horizon = plan.inputs.rows();
  const Eigen::Index predicted = model_free ? 0 : horizon;  // model-free: no predictions
  if (horizon < 1 || plan.inputs.cols() != spec_.input_dim ||
      plan.states.rows() != predicted || plan.variances.rows() != predicted ||
      (predicted > 0 && (plan.states.cols() != spec_.state_dim ||
                         plan.variances.cols() != spec_.state_dim))) {
    return absl::InternalError(absl::StrCat("planning for session ", name_,
                                            " returned a plan of the wrong shape"));
  }
  return absl::OkStatus();
}

absl::StatusOr<PlanResult> Session::PlanInputs(const Eigen::VectorXd& state,
                                               const Eigen::MatrixXd& pending,
                                               Clock::time_point deadline,
                                               std::function<bool()> cancelled) {
  const CallScope call(this);
  absl::MutexLock plan_lock(&plan_mu_);
  // prbs, chirp and random never evaluate the model: no data needed, no refit.
  const bool model_free = plan::IsModelFree(planner_.options().strategy);
  PlanResult result;
  result.start_step = static_cast<int>(pending.rows());
  int64_t start = 0;
  plan::PlanStart plan_start;
  const gp::DynamicsModel* model = nullptr;
  {
    absl::MutexLock lock(&mu_);
    if (absl::Status s = CheckUsable(); !s.ok()) return s;
    if (!model_free) {
      if (absl::Status s = EnsureFitted(deadline, cancelled); !s.ok()) return s;
    }
    mu_.Await(absl::Condition(&NotInUse, &model_in_use_));  // a fit by a read
    // (A cancel is the planner's to notice, outside the lock.)
    if (Clock::now() >= deadline) {
      return absl::DeadlineExceededError(absl::StrCat(
          "PlanInputs on ", name_, ": the deadline passed before planning started"));
    }
    start = sample_count_ + result.start_step;
    plan_start.measured = pending.rows() == 0;
    if (pending.rows() > 0 || last_plan_pending_) {
      plan_start.steps_since_previous = start - last_plan_start_;
    }
    result.model_version = model_version_;
    model = &*model_;
    model_in_use_ = true;
  }
  // Outside mu_: reads and AddData go on meanwhile, and nothing changes *model.
  plan::PlanLimits limits;
  limits.deadline = deadline;
  limits.cancelled = std::move(cancelled);
  absl::Status start_error;
  absl::StatusOr<plan::Plan> plan;
  try {
    absl::StatusOr<Eigen::VectorXd> x0 = model_free
                                             ? absl::StatusOr<Eigen::VectorXd>(state)
                                             : StateAfter(*model, state, pending, name_);
    if (x0.ok()) {
      plan = planner_.PlanInputs(*model, *x0, start, limits, &result.summary, plan_start);
    } else {
      start_error = x0.status();
    }
  } catch (const std::exception& e) {
    plan = InternalFromException("planner", e);
  }
  absl::MutexLock lock(&mu_);
  model_in_use_ = false;
  ApplyDeferred();
  if (!start_error.ok()) return start_error;
  if (!plan.ok()) {
    const absl::StatusCode code = plan.status().code();
    if (code == absl::StatusCode::kCancelled ||
        code == absl::StatusCode::kDeadlineExceeded ||
        code == absl::StatusCode::kInvalidArgument) {
      return plan.status();
    }
    return absl::InternalError(absl::StrCat("planning for session ", name_,
                                            " failed: ", plan.status().ToString()));
  }
  // Deleted or moved while it planned: the plan is nobody's.
  if (absl::Status s = CheckUsable(); !s.ok()) return s;
  if (absl::Status s = CheckPlanShape(*plan, model_free); !s.ok()) return s;
  result.plan = *std::move(plan);
  result.plan.apply_count =
      std::clamp(result.plan.apply_count, 1, static_cast<int>(result.plan.inputs.rows()));
  last_plan_ = result;
  last_plan_start_ = start;
  last_plan_pending_ = pending.rows() > 0;
  PublishSnapshot();
  {
    PlanRecord record;
    record.sample_count = start - result.start_step;
    record.model_version = result.model_version;
    record.unix_ms = absl::ToUnixMillis(absl::Now());
    record.planned_by = result.summary.planned_by;
    record.status = result.summary.status;
    record.objective = result.summary.objective;
    record.wall_time_ms = result.summary.wall_time_ms;
    record.iterations = result.summary.iterations;
    absl::MutexLock history_lock(&snapshot_mu_);
    history_.Add(record);
  }
  return result;
}

absl::StatusOr<StoredSession> Session::Export() {
  const CallScope call(this);
  absl::MutexLock lock(&mu_);
  if (deleted_) return NotDeleted(name_);  // a damaged session exports what is stored
  if (stale()) return StaleError();
  absl::StatusOr<store::SessionRecord> record = store_->LoadSession(id_);
  if (!record.ok()) {
    if (absl::IsNotFound(record.status())) return NotDeleted(name_);
    return record.status();
  }
  // A damaged session exports the rows that can be read.
  std::vector<int64_t> unreadable;
  absl::StatusOr<std::vector<store::SampleRecord>> samples =
      store_->LoadSamples(id_, damaged_.ok() ? nullptr : &unreadable);
  if (!samples.ok()) return samples.status();
  return StoredSession{*std::move(record), *std::move(samples)};
}

absl::Status Session::Delete() {
  const CallScope call(this);
  absl::MutexLock lock(&mu_);
  if (deleted_) return NotDeleted(name_);
  if (stale()) return StaleError();
  absl::Status status = store_->DeleteSession(id_, fence_);
  if (!status.ok() && !absl::IsNotFound(status)) {
    return StoreWriteFailed(status, "deleting");
  }
  deleted_ = true;
  if (budget_ != nullptr) budget_->Release(reserved_bytes_);
  reserved_bytes_ = 0;
  return absl::OkStatus();
}

void Session::AttachMemoryBudget(MemoryBudget* budget, int64_t reserved) {
  absl::MutexLock lock(&mu_);
  budget_ = budget;
  reserved_bytes_ = reserved;
}

int64_t Session::EstimatedBytes(int64_t samples) const {
  const gp::DynamicsModelOptions& options = spec_.model;
  return kSessionBytes + gp::DynamicsModel::PeakBytes(
                             samples, spec_.state_dim, spec_.input_dim, FitThreads(),
                             options.sparse_above, options.sparse.max_inducing,
                             options.sparse_fit_samples);
}

void Session::SettleBudget() {
  if (budget_ == nullptr) return;
  const int64_t held = EstimatedBytes(sample_count_);
  budget_->Release(reserved_bytes_ - held);
  reserved_bytes_ = held;
}

}  // namespace excite::session
