#include "server/service/exploration_service.h"

#include <algorithm>
#include <chrono>
#include <exception>
#include <string>
#include <utility>

#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/strip.h"
#include "absl/time/clock.h"
#include "common/logging.h"
#include "model_file/model_file.h"
#include "server/service/config_validation.h"
#include "server/service/field_violation.h"
#include "server/service/grpc_status.h"
#include "server/service/request_validation.h"
#include "server/service/resource_name.h"
#include "server/service/session_archive.h"
#include "server/service/session_labels.h"
#include "server/service/session_options.h"
#include "server/service/session_proto.h"
#include "server/service/store_conversion.h"

namespace excite::service {

using session::AddResult;
using session::Prediction;
using session::SessionSnapshot;
using session::SessionSpec;
using session::StoredSession;

namespace {

using Clock = std::chrono::steady_clock;

// The client's deadline minus a margin for the reply, as a steady-clock time;
// time_point::max() if the client set none.
Clock::time_point ClientDeadline(const grpc::ServerContext& context) {
  const auto client_left = context.deadline() - std::chrono::system_clock::now();
  // gRPC reports "no deadline" as a time point far in the future.
  if (client_left >= std::chrono::hours(24 * 365)) return Clock::time_point::max();
  auto left = std::chrono::duration_cast<Clock::duration>(client_left);
  // Leave time to send the reply: 10% of what is left, at most 50 ms.
  left -= std::min<Clock::duration>(left / 10, std::chrono::milliseconds(50));
  return Clock::now() + left;
}

// min(ClientDeadline, now + budget): of PlanInputs, and of a Predict's refit.
Clock::time_point BudgetDeadline(const grpc::ServerContext& context, double budget_s) {
  const Clock::time_point budget_end =
      Clock::now() + std::chrono::duration_cast<Clock::duration>(
                         std::chrono::duration<double>(budget_s));
  return std::min(ClientDeadline(context), budget_end);
}

}  // namespace

ExplorationService::ExplorationService(SessionRegistry* registry, ServiceLimits limits)
    : registry_(registry), limits_(limits) {}

void ExplorationService::StartDraining() {
  absl::MutexLock lock(&mu_);
  draining_ = true;
}

bool ExplorationService::Draining() const {
  absl::MutexLock lock(&mu_);
  return draining_;
}

bool ExplorationService::WaitIdle(absl::Duration timeout) {
  absl::MutexLock lock(&mu_);
  const auto idle = [this]()
                        ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) { return in_flight_ == 0; };
  return mu_.AwaitWithTimeout(absl::Condition(&idle), timeout);
}

template <typename Body>
grpc::Status ExplorationService::RunRpc(absl::string_view method,
                                        const std::string& session, Body&& body) {
  const Clock::time_point start = Clock::now();
  absl::Status status;
  bool admitted = false;
  {
    absl::MutexLock lock(&mu_);
    if (!draining_) {
      ++in_flight_;
      admitted = true;
    }
  }
  if (!admitted) {
    status = absl::UnavailableError("excite-server is shutting down: retry later");
  } else {
    try {
      status = body();
    } catch (const std::exception& e) {
      status =
          absl::InternalError(absl::StrCat(method, ": unexpected exception: ", e.what()));
    } catch (...) {
      status = absl::InternalError(absl::StrCat(method, ": unexpected exception"));
    }
    absl::MutexLock lock(&mu_);
    --in_flight_;
  }
  if (LogEnabled(LogLevel::kDebug) ||
      (!status.ok() && status.code() == absl::StatusCode::kInternal)) {
    const double ms =
        std::chrono::duration<double, std::milli>(Clock::now() - start).count();
    Log(status.code() == absl::StatusCode::kInternal ? LogLevel::kError
                                                     : LogLevel::kDebug,
        absl::StrCat("rpc ", method, " session=", session.empty() ? "-" : session,
                     " status=", absl::StatusCodeToString(status.code()),
                     status.ok() ? "" : absl::StrCat(" (", status.message(), ")"),
                     " ms=", absl::SixDigits(ms)));
  }
  return ToGrpcStatus(status);
}

absl::StatusOr<std::shared_ptr<Session>> ExplorationService::FindSession(
    const std::string& name, absl::string_view field) {
  absl::StatusOr<std::string> id = ParseSessionName(name, field);
  if (!id.ok()) return id.status();
  return registry_->Get(*id);
}

absl::StatusOr<std::shared_ptr<Session>> ExplorationService::FindUndamagedSession(
    const std::string& name, absl::string_view field) {
  absl::StatusOr<std::shared_ptr<Session>> session = FindSession(name, field);
  if (!session.ok()) return session.status();
  if (absl::Status s = (*session)->Damage(); !s.ok()) return s;
  return session;
}

absl::Status ExplorationService::CheckHorizonCap(const v1::SessionConfig& validated,
                                                 absl::string_view field) const {
  if (validated.horizon() <= limits_.max_horizon) return absl::OkStatus();
  return absl::ResourceExhaustedError(
      absl::StrCat(field, ": ", validated.horizon(), " exceeds this server's cap of ",
                   limits_.max_horizon, " (--max_horizon)"));
}

grpc::Status ExplorationService::CreateSession(grpc::ServerContext* /*context*/,
                                               const v1::CreateSessionRequest* request,
                                               v1::Session* response) {
  return RunRpc("CreateSession", request->session_id(), [&]() -> absl::Status {
    // The server's horizon cap applies to the horizon after defaults (an invalid
    // config is reported with every other problem below).
    absl::StatusOr<v1::SessionConfig> validated =
        ValidatedSessionConfig(request->config(), "config");
    if (validated.ok()) {
      if (absl::Status s = CheckHorizonCap(*validated, "config.horizon"); !s.ok()) {
        return s;
      }
    }
    Violations problems;
    problems.Add(CheckOptionalSessionId(request->session_id(), "session_id"));
    problems.Add(validated.status());
    problems.Add(
        ValidateDisplayNameAndLabels(request->display_name(), request->labels()));
    if (absl::Status s = problems.Result(); !s.ok()) return s;
    absl::StatusOr<SessionDescription> created = registry_->Create(
        request->session_id(), SessionSpecFromConfig(*validated), request->display_name(),
        Labels(request->labels().begin(), request->labels().end()));
    if (!created.ok()) return created.status();
    *response = SessionToProto(*created);
    Log(LogLevel::kInfo, absl::StrCat("created ", response->name()));
    return absl::OkStatus();
  });
}

grpc::Status ExplorationService::GetSession(grpc::ServerContext* /*context*/,
                                            const v1::GetSessionRequest* request,
                                            v1::Session* response) {
  return RunRpc("GetSession", request->name(), [&]() -> absl::Status {
    absl::StatusOr<std::string> id = ParseSessionName(request->name(), "name");
    if (!id.ok()) return id.status();
    absl::StatusOr<SessionDescription> described = registry_->Describe(*id);
    if (!described.ok()) return described.status();
    *response = SessionToProto(*described);
    return absl::OkStatus();
  });
}

grpc::Status ExplorationService::GetSessionHistory(
    grpc::ServerContext* /*context*/, const v1::GetSessionHistoryRequest* request,
    v1::SessionHistory* response) {
  return RunRpc("GetSessionHistory", request->name(), [&]() -> absl::Status {
    absl::StatusOr<std::string> id = ParseSessionName(request->name(), "name");
    if (!id.ok()) return id.status();
    absl::StatusOr<session::LearningHistory> history = registry_->History(*id);
    if (!history.ok()) return history.status();
    *response = HistoryToProto(*history);
    return absl::OkStatus();
  });
}

grpc::Status ExplorationService::ExportModel(grpc::ServerContext* context,
                                             const v1::ExportModelRequest* request,
                                             v1::ExportModelResponse* response) {
  return RunRpc("ExportModel", request->name(), [&]() -> absl::Status {
    absl::StatusOr<std::shared_ptr<Session>> session =
        FindUndamagedSession(request->name(), "name");
    if (!session.ok()) return session.status();
    absl::StatusOr<session::ModelExport> exported = (*session)->ExportModel(
        BudgetDeadline(*context, (*session)->spec().time_budget_s),
        [context]() { return context->IsCancelled(); });
    if (!exported.ok()) return exported.status();
    std::string file = model::EncodeModelFile(exported->model);
    if (file.size() + 64 > static_cast<size_t>(limits_.max_message_bytes)) {
      return absl::ResourceExhaustedError(absl::StrCat(
          "the model file of ", request->name(), " (", exported->model.sample_count,
          " samples) is ", file.size(),
          " bytes, more than this server's message limit of ", limits_.max_message_bytes,
          " bytes: restart excite-server with a larger --max_message_mb to export it"));
    }
    response->set_model_file(std::move(file));
    response->set_format_version(model::ModelFileVersion(exported->model));
    response->set_model_version(exported->model_version);
    response->set_sample_count(exported->model.sample_count);
    return absl::OkStatus();
  });
}

grpc::Status ExplorationService::ListSessions(grpc::ServerContext* /*context*/,
                                              const v1::ListSessionsRequest* request,
                                              v1::ListSessionsResponse* response) {
  return RunRpc("ListSessions", "", [&]() -> absl::Status {
    absl::StatusOr<LabelFilter> filter = LabelFilter::Parse(request->filter());
    if (!filter.ok()) return filter.status();
    absl::StatusOr<SessionRegistry::Page> page = registry_->List(
        request->page_size(), request->page_token(),
        [&filter](const Labels& labels) { return filter->Matches(labels); });
    if (!page.ok()) return page.status();
    for (const SessionDescription& session : page->sessions) {
      *response->add_sessions() = SessionToProto(session);
    }
    response->set_next_page_token(page->next_page_token);
    return absl::OkStatus();
  });
}

grpc::Status ExplorationService::DeleteSession(grpc::ServerContext* /*context*/,
                                               const v1::DeleteSessionRequest* request,
                                               v1::DeleteSessionResponse* /*response*/) {
  return RunRpc("DeleteSession", request->name(), [&]() -> absl::Status {
    absl::StatusOr<std::string> id = ParseSessionName(request->name(), "name");
    if (!id.ok()) return id.status();
    if (absl::Status s = registry_->Delete(*id); !s.ok()) return s;
    Log(LogLevel::kInfo, absl::StrCat("deleted ", request->name()));
    return absl::OkStatus();
  });
}

absl::StatusOr<v1::AddDataResponse> ExplorationService::AddMessage(
    const v1::AddDataRequest& request, int64_t message_index,
    std::shared_ptr<Session>* session) {
  if (*session == nullptr) {
    if (request.session().empty()) {
      return absl::InvalidArgumentError(
          "session: required in the first message of the stream (\"sessions/{id}\")");
    }
    absl::StatusOr<std::shared_ptr<Session>> found =
        FindUndamagedSession(request.session(), "session");
    if (!found.ok()) return found.status();
    *session = *std::move(found);
  } else if (!request.session().empty() && request.session() != (*session)->name()) {
    return absl::InvalidArgumentError(
        absl::StrCat("session: message ", message_index, " names ",
                     absl::CHexEscape(request.session().substr(0, 100)),
                     " but the stream started with ", (*session)->name()));
  }
  const auto naming_the_message = [message_index](const absl::Status& s) {
    return WithMessage(s, absl::StrCat("message ", message_index, ": ", s.message()));
  };
  const SessionSpec& spec = (*session)->spec();
  if (absl::Status s = ValidateTransitions(DimsOf(spec), request.transitions());
      !s.ok()) {
    return naming_the_message(s);
  }
  std::vector<store::SampleRecord> batch;
  batch.reserve(static_cast<size_t>(request.transitions_size()));
  for (const v1::Transition& t : request.transitions())
    batch.push_back(ToSampleRecord(t));
  absl::StatusOr<AddResult> added =
      (*session)->AddSamples(batch, limits_.max_samples_per_session);
  if (absl::IsInvalidArgument(added.status())) {
    // The model refused the batch (Session::AddSamples: "transitions: ...").
    return naming_the_message(FieldViolationError(
        "transitions", absl::StripPrefix(added.status().message(), "transitions: ")));
  }
  if (!added.ok()) return added.status();
  v1::AddDataResponse response;
  response.set_stored(added->stored);
  response.set_duplicates(added->duplicates);
  response.set_sample_count(added->sample_count);
  response.set_model_version(added->model_version);
  return response;
}

grpc::Status ExplorationService::AddData(grpc::ServerContext* context,
                                         grpc::ServerReader<v1::AddDataRequest>* reader,
                                         v1::AddDataResponse* response) {
  std::string name;  // the stream's session, for the log line
  return RunRpc("AddData", name, [&]() -> absl::Status {
    std::shared_ptr<Session> session;
    v1::AddDataRequest request;
    int64_t stored = 0;
    int64_t duplicates = 0;
    for (int64_t index = 0; reader->Read(&request); ++index) {
      absl::StatusOr<v1::AddDataResponse> added = AddMessage(request, index, &session);
      if (!added.ok()) {
        // Earlier messages are stored, but this reply is the stream's only one:
        // say so (StreamData acknowledges each message instead).
        return index == 0
                   ? added.status()
                   : WithMessage(added.status(),
                                 absl::StrCat(added.status().message(), " (messages 0-",
                                              index - 1, " of the stream are stored)"));
      }
      name = session->name();
      stored += added->stored();
      duplicates += added->duplicates();
    }
    if (session == nullptr) {
      return absl::InvalidArgumentError(
          "session: the AddData stream carried no message naming a session");
    }
    if (context->IsCancelled()) {
      return absl::CancelledError("AddData was cancelled by the client");
    }
    response->set_stored(stored);
    response->set_duplicates(duplicates);
    const SessionSnapshot snapshot = session->Snapshot();
    response->set_sample_count(snapshot.sample_count);
    response->set_model_version(snapshot.model_version);
    return absl::OkStatus();
  });
}

grpc::Status ExplorationService::StreamData(
    grpc::ServerContext* context,
    grpc::ServerReaderWriter<v1::AddDataAck, v1::AddDataRequest>* stream) {
  std::string name;  // the stream's session, for the log line
  return RunRpc("StreamData", name, [&]() -> absl::Status {
    std::shared_ptr<Session> session;
    v1::AddDataRequest request;
    for (int64_t index = 0; stream->Read(&request); ++index) {
      absl::StatusOr<v1::AddDataResponse> added = AddMessage(request, index, &session);
      if (!added.ok()) return added.status();
      name = session->name();
      v1::AddDataAck ack;
      ack.set_message_index(index);
      ack.set_stored(added->stored());
      ack.set_duplicates(added->duplicates());
      ack.set_sample_count(added->sample_count());
      ack.set_model_version(added->model_version());
      if (!stream->Write(ack)) {
        return absl::CancelledError(absl::StrCat(
            "StreamData: the client went away; message ", index, " is stored"));
      }
      if (Draining()) {
        return absl::UnavailableError(absl::StrCat(
            "excite-server is shutting down: message ", index,
            " and those before it are stored; resend the rest to another replica or "
            "later"));
      }
    }
    if (context->IsCancelled()) {
      return absl::CancelledError("StreamData was cancelled by the client");
    }
    return absl::OkStatus();
  });
}

grpc::Status ExplorationService::Predict(grpc::ServerContext* context,
                                         const v1::PredictRequest* request,
                                         v1::PredictResponse* response) {
  return RunRpc("Predict", request->session(), [&]() -> absl::Status {
    absl::StatusOr<std::shared_ptr<Session>> session =
        FindUndamagedSession(request->session(), "session");
    if (!session.ok()) return session.status();
    const SessionSpec& spec = (*session)->spec();
    if (absl::Status s = ValidatePredictInputs(DimsOf(spec), request->inputs(),
                                               limits_.max_predict_points);
        !s.ok()) {
      return s;
    }
    const int z_dim = spec.state_dim + spec.input_dim;
    absl::StatusOr<Prediction> predicted = (*session)->Predict(
        RowMajorToMatrix(request->inputs(), request->inputs_size() / z_dim, z_dim),
        request->include_noise(), BudgetDeadline(*context, spec.time_budget_s),
        ClientDeadline(*context), [context]() { return context->IsCancelled(); });
    if (!predicted.ok()) return predicted.status();
    AppendRowMajor(predicted->mean, response->mutable_mean());
    AppendRowMajor(predicted->variance, response->mutable_variance());
    response->set_model_version(predicted->model_version);
    return absl::OkStatus();
  });
}

grpc::Status ExplorationService::Rollout(grpc::ServerContext* context,
                                         const v1::RolloutRequest* request,
                                         v1::RolloutResponse* response) {
  return RunRpc("Rollout", request->session(), [&]() -> absl::Status {
    absl::StatusOr<std::shared_ptr<Session>> session =
        FindUndamagedSession(request->session(), "session");
    if (!session.ok()) return session.status();
    const SessionSpec& spec = (*session)->spec();
    if (absl::Status s = ValidateRollout(DimsOf(spec), *request); !s.ok()) return s;
    const Eigen::Index steps = request->inputs_size() / spec.input_dim;
    const Eigen::VectorXd variance =
        request->state_variance().empty()
            ? Eigen::VectorXd::Zero(spec.state_dim)
            : Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(
                  request->state_variance().data(), spec.state_dim));
    absl::StatusOr<session::RolloutResult> rolled = (*session)->Rollout(
        Eigen::Map<const Eigen::VectorXd>(request->state().data(), spec.state_dim),
        variance, RowMajorToMatrix(request->inputs(), steps, spec.input_dim),
        request->include_noise(), BudgetDeadline(*context, spec.time_budget_s),
        [context]() { return context->IsCancelled(); });
    if (!rolled.ok()) return rolled.status();
    const plan::PropagatedTrajectory& t = rolled->trajectory;
    AppendRowMajor(t.means, response->mutable_means());
    for (const Eigen::MatrixXd& c : t.covariances) {
      AppendRowMajor(c, response->mutable_covariances());
      for (Eigen::Index j = 0; j < c.rows(); ++j) response->add_variances(c(j, j));
    }
    response->set_model_version(rolled->model_version);
    return absl::OkStatus();
  });
}

grpc::Status ExplorationService::PlanInputs(grpc::ServerContext* context,
                                            const v1::PlanInputsRequest* request,
                                            v1::PlanInputsResponse* response) {
  return RunRpc("PlanInputs", request->session(), [&]() -> absl::Status {
    absl::StatusOr<std::shared_ptr<Session>> session =
        FindUndamagedSession(request->session(), "session");
    if (!session.ok()) return session.status();
    const SessionSpec& spec = (*session)->spec();
    if (absl::Status s = ValidatePlanRequest(DimsOf(spec), spec.plan.horizon, *request);
        !s.ok()) {
      return s;
    }
    const Clock::time_point deadline = BudgetDeadline(*context, spec.time_budget_s);
    absl::StatusOr<PlanResult> plan = (*session)->PlanInputs(
        Eigen::Map<const Eigen::VectorXd>(request->state().data(), request->state_size()),
        RowMajorToMatrix(request->pending_inputs(),
                         request->pending_inputs_size() / spec.input_dim, spec.input_dim),
        deadline, [context]() { return context->IsCancelled(); });
    if (!plan.ok()) return plan.status();
    if (context->IsCancelled()) {
      return absl::CancelledError("PlanInputs was cancelled by the client");
    }
    *response = PlanToProto(*plan);
    return absl::OkStatus();
  });
}

grpc::Status ExplorationService::ExportSession(grpc::ServerContext* /*context*/,
                                               const v1::ExportSessionRequest* request,
                                               v1::SessionArchive* response) {
  return RunRpc("ExportSession", request->name(), [&]() -> absl::Status {
    absl::StatusOr<std::shared_ptr<Session>> session =
        FindSession(request->name(), "name");
    if (!session.ok()) return session.status();
    absl::StatusOr<StoredSession> stored = (*session)->Export();
    if (!stored.ok()) return stored.status();
    v1::SessionArchive archive = ArchiveFromStore(stored->record, stored->samples);
    const size_t bytes = archive.ByteSizeLong();
    if (bytes > static_cast<size_t>(limits_.max_message_bytes)) {
      return absl::ResourceExhaustedError(absl::StrCat(
          "the archive of ", request->name(), " (", archive.samples_size(),
          " samples) is ", bytes, " bytes, more than this server's message limit of ",
          limits_.max_message_bytes,
          " bytes: restart excite-server with a larger --max_message_mb to export it"));
    }
    *response = std::move(archive);
    return absl::OkStatus();
  });
}

grpc::Status ExplorationService::ImportSession(grpc::ServerContext* /*context*/,
                                               const v1::ImportSessionRequest* request,
                                               v1::Session* response) {
  const std::string& id_for_log = request->session_id().empty()
                                      ? request->archive().session_id()
                                      : request->session_id();
  return RunRpc("ImportSession", id_for_log, [&]() -> absl::Status {
    if (absl::Status s = CheckOptionalSessionId(request->session_id(), "session_id");
        !s.ok()) {
      return s;
    }
    absl::StatusOr<v1::SessionConfig> config =
        ValidateSessionArchive(request->archive(), "archive");
    if (!config.ok()) return config.status();
    if (absl::Status s = CheckHorizonCap(*config, "archive.config.horizon"); !s.ok()) {
      return s;
    }
    if (request->archive().samples_size() > limits_.max_samples_per_session) {
      return absl::ResourceExhaustedError(absl::StrCat(
          "archive.samples: ", request->archive().samples_size(),
          " samples exceed this server's cap of ", limits_.max_samples_per_session,
          " per session (--max_samples_per_session)"));
    }
    ArchiveRecords records =
        ArchiveToStore(request->archive(), *config, absl::ToUnixMillis(absl::Now()));
    const std::string& id = request->session_id().empty()
                                ? request->archive().session_id()
                                : request->session_id();
    absl::StatusOr<SessionDescription> imported =
        registry_->Import(id, std::move(records.record), records.samples);
    if (!imported.ok()) return imported.status();
    *response = SessionToProto(*imported);
    Log(LogLevel::kInfo, absl::StrCat("imported ", response->name(), " with ",
                                      records.samples.size(), " samples"));
    return absl::OkStatus();
  });
}

}  // namespace excite::service
