#include "client/excite_client.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <thread>
#include <utility>

#include "absl/status/status.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/strip.h"
#include "grpcpp/create_channel.h"
#include "grpcpp/security/credentials.h"

namespace excite::client {
namespace {

// gRPC's own message-size check (RESOURCE_EXHAUSTED "... larger than max ...")
// with `hint` appended; any other status as it is.
absl::Status WithSizeHint(const absl::Status& status, absl::string_view hint) {
  if (!absl::IsResourceExhausted(status) ||
      !absl::StrContains(status.message(), "larger than max")) {
    return status;
  }
  return absl::Status(status.code(), absl::StrCat(status.message(), " (", hint, ")"));
}

template <typename T>
const absl::Status& StatusOf(const absl::StatusOr<T>& result) {
  return result.status();
}

absl::Status FromGrpc(const grpc::Status& status) {
  if (status.ok()) return absl::OkStatus();
  const int code = static_cast<int>(status.error_code());
  const absl::StatusCode absl_code = code >= 1 && code <= 16
                                         ? static_cast<absl::StatusCode>(code)
                                         : absl::StatusCode::kUnknown;
  return absl::Status(absl_code, status.error_message());
}

bool ReadFile(const std::string& path, std::string* contents) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  std::ostringstream buffer;
  buffer << in.rdbuf();
  *contents = buffer.str();
  return true;
}

std::shared_ptr<grpc::ChannelCredentials> MakeCredentials(const ClientOptions& options) {
  if (options.tls_ca_file.empty()) return grpc::InsecureChannelCredentials();
  grpc::SslCredentialsOptions ssl;
  if (!ReadFile(options.tls_ca_file, &ssl.pem_root_certs) ||
      (!options.tls_cert_file.empty() &&
       !ReadFile(options.tls_cert_file, &ssl.pem_cert_chain)) ||
      (!options.tls_key_file.empty() &&
       !ReadFile(options.tls_key_file, &ssl.pem_private_key))) {
    return nullptr;
  }
  return grpc::SslCredentials(ssl);
}

}  // namespace

absl::StatusOr<std::string> LoadAuthToken(const std::string& token_file) {
  if (token_file.empty()) {
    const char* env = std::getenv("EXCITE_AUTH_TOKEN");
    return std::string(env != nullptr ? env : "");
  }
  std::string contents;
  if (!ReadFile(token_file, &contents)) {
    return absl::InvalidArgumentError(absl::StrCat("cannot read ", token_file));
  }
  return std::string(absl::StripAsciiWhitespace(contents));
}

void ExciteClient::Prepare(grpc::ClientContext* context,
                           std::chrono::milliseconds timeout,
                           const std::string& session) const {
  context->set_deadline(std::chrono::system_clock::now() + timeout);
  if (!options_.auth_token.empty()) {
    context->AddMetadata("authorization", "Bearer " + options_.auth_token);
  }
  if (!session.empty()) {
    // The id alone, as the Python client sends it: one hash key per session.
    const size_t slash = session.find('/');
    context->AddMetadata(
        kSessionHeader, slash == std::string::npos ? session : session.substr(slash + 1));
  }
}

template <typename Attempt>
auto ExciteClient::Retrying(Attempt&& attempt, Resend resend) const
    -> decltype(attempt()) {
  using Clock = std::chrono::steady_clock;
  const Clock::time_point give_up = Clock::now() + options_.retry_unavailable;
  std::chrono::milliseconds backoff(50);
  while (true) {
    auto result = attempt();
    const absl::Status& status = StatusOf(result);
    const bool retryable =
        absl::IsUnavailable(status) ||
        (resend != Resend::kIfUnavailable && absl::IsUnknown(status)) ||
        (resend == Resend::kAfterLostAnswerOrDeadline &&
         absl::IsDeadlineExceeded(status));
    if (!retryable || Clock::now() + backoff >= give_up) return result;
    std::this_thread::sleep_for(backoff);
    backoff = std::min<std::chrono::milliseconds>(backoff * 2, std::chrono::seconds(2));
  }
}

ExciteClient::ExciteClient(std::shared_ptr<grpc::Channel> channel, ClientOptions options)
    : channel_(std::move(channel)),
      stub_(v1::ExplorationService::NewStub(channel_)),
      options_(options) {}

std::shared_ptr<grpc::Channel> CreateChannel(const std::string& target,
                                             const ClientOptions& options) {
  grpc::ChannelArguments args;
  // Match the server's message cap (default 64 MiB) for large Predict batches
  // and session archives.
  const int max_bytes = std::clamp(options.max_message_mb, 1, 2047) * 1024 * 1024;
  args.SetMaxReceiveMessageSize(max_bytes);
  args.SetMaxSendMessageSize(max_bytes);
  std::shared_ptr<grpc::ChannelCredentials> credentials = MakeCredentials(options);
  // Unreadable TLS files: a channel that never connects (calls: UNAVAILABLE).
  return credentials != nullptr ? grpc::CreateCustomChannel(target, credentials, args)
                                : grpc::CreateCustomChannel(
                                      target, grpc::SslCredentials({"-", "", ""}), args);
}

std::unique_ptr<ExciteClient> ExciteClient::Connect(const std::string& target,
                                                    ClientOptions options) {
  std::shared_ptr<grpc::Channel> channel = CreateChannel(target, options);
  return std::unique_ptr<ExciteClient>(new ExciteClient(std::move(channel), options));
}

absl::Status ExciteClient::WaitForReady(std::chrono::milliseconds timeout) {
  if (channel_->WaitForConnected(std::chrono::system_clock::now() + timeout)) {
    return absl::OkStatus();
  }
  return absl::UnavailableError(
      absl::StrCat("could not connect within ", timeout.count(), " ms"));
}

absl::StatusOr<v1::Session> ExciteClient::CreateSession(const v1::SessionConfig& config,
                                                        const std::string& session_id) {
  v1::CreateSessionRequest request;
  request.set_session_id(session_id);
  *request.mutable_config() = config;
  return CreateSession(request);
}

absl::StatusOr<v1::Session> ExciteClient::CreateSession(
    const v1::CreateSessionRequest& request) {
  return Unary(&v1::ExplorationService::Stub::CreateSession, request,
               request.session_id(), options_.default_deadline, Resend::kIfUnavailable);
}

absl::StatusOr<v1::Session> ExciteClient::GetSession(const std::string& name) {
  v1::GetSessionRequest request;
  request.set_name(name);
  return Unary(&v1::ExplorationService::Stub::GetSession, request, name,
               options_.default_deadline, Resend::kAfterLostAnswer);
}

absl::StatusOr<v1::RolloutResponse> ExciteClient::Rollout(
    const v1::RolloutRequest& request) {
  return Unary(&v1::ExplorationService::Stub::Rollout, request, request.session(),
               options_.default_deadline, Resend::kAfterLostAnswer);
}

absl::StatusOr<v1::ExportModelResponse> ExciteClient::ExportModel(
    const std::string& name) {
  v1::ExportModelRequest request;
  request.set_name(name);
  return Unary(&v1::ExplorationService::Stub::ExportModel, request, name,
               options_.default_deadline, Resend::kAfterLostAnswer);
}

absl::StatusOr<v1::SessionHistory> ExciteClient::GetSessionHistory(
    const std::string& name) {
  v1::GetSessionHistoryRequest request;
  request.set_name(name);
  return Unary(&v1::ExplorationService::Stub::GetSessionHistory, request, name,
               options_.default_deadline, Resend::kAfterLostAnswer);
}

absl::StatusOr<v1::ListSessionsResponse> ExciteClient::ListSessions(
    int page_size, const std::string& page_token, const std::string& filter) {
  v1::ListSessionsRequest request;
  request.set_page_size(page_size);
  request.set_page_token(page_token);
  request.set_filter(filter);
  return Unary(&v1::ExplorationService::Stub::ListSessions, request, "",
               options_.default_deadline, Resend::kAfterLostAnswer);
}

absl::Status ExciteClient::DeleteSession(const std::string& name) {
  v1::DeleteSessionRequest request;
  request.set_name(name);
  return Unary(&v1::ExplorationService::Stub::DeleteSession, request, name,
               options_.default_deadline, Resend::kIfUnavailable)
      .status();
}

absl::StatusOr<v1::AddDataResponse> ExciteClient::AddData(
    const std::string& session, const std::vector<std::vector<v1::Transition>>& batches) {
  auto attempt = [&]() -> absl::StatusOr<v1::AddDataResponse> {
    grpc::ClientContext context;
    Prepare(&context, options_.data_deadline, session);
    v1::AddDataResponse response;
    std::unique_ptr<grpc::ClientWriter<v1::AddDataRequest>> writer =
        stub_->AddData(&context, &response);
    for (size_t i = 0; i < batches.size(); ++i) {
      v1::AddDataRequest request;
      request.set_session(session);
      request.mutable_transitions()->Reserve(static_cast<int>(batches[i].size()));
      for (const v1::Transition& t : batches[i]) *request.add_transitions() = t;
      // A failed write means the stream is closed (the server answered early
      // with an error): Finish() below carries the reason.
      if (!writer->Write(request)) break;
    }
    writer->WritesDone();
    if (absl::Status s = FromGrpc(writer->Finish()); !s.ok()) return s;
    return response;
  };
  return Retrying(attempt, Resend::kAfterLostAnswerOrDeadline);
}

std::unique_ptr<DataStream> ExciteClient::OpenDataStream(
    const std::string& session, std::chrono::milliseconds deadline) {
  std::unique_ptr<DataStream> stream(new DataStream());
  stream->session_ = session;
  Prepare(&stream->context_, deadline, session);
  stream->stream_ = stub_->StreamData(&stream->context_);
  return stream;
}

DataStream::~DataStream() {
  if (!done_) {
    context_.TryCancel();
    stream_->Finish().ok();  // ends the call; the status no longer matters
  }
}

absl::StatusOr<v1::AddDataAck> DataStream::Send(
    const std::vector<v1::Transition>& batch) {
  if (done_) {
    return absl::FailedPreconditionError(absl::StrCat(
        "the stream has ended (", finished_.ToString(), "): open a new one"));
  }
  v1::AddDataRequest request;
  request.set_session(session_);
  request.mutable_transitions()->Reserve(static_cast<int>(batch.size()));
  for (const v1::Transition& t : batch) *request.add_transitions() = t;
  v1::AddDataAck ack;
  if (stream_->Write(request) && stream_->Read(&ack)) return ack;
  // The server ended the stream (an error) or it broke: Finish() says which.
  done_ = true;
  finished_ = FromGrpc(stream_->Finish());
  if (finished_.ok()) {
    finished_ = absl::UnavailableError("the server ended the stream without an answer");
  }
  return finished_;
}

absl::Status DataStream::Close() {
  if (done_) return finished_;
  done_ = true;
  stream_->WritesDone();
  finished_ = FromGrpc(stream_->Finish());
  return finished_;
}

absl::StatusOr<v1::PredictResponse> ExciteClient::Predict(
    const v1::PredictRequest& request) {
  return Unary(&v1::ExplorationService::Stub::Predict, request, request.session(),
               options_.default_deadline, Resend::kAfterLostAnswer);
}

absl::StatusOr<v1::PlanInputsResponse> ExciteClient::PlanInputs(
    const std::string& session, const std::vector<double>& state,
    const std::vector<double>& pending_inputs) {
  v1::PlanInputsRequest request;
  request.set_session(session);
  request.mutable_state()->Add(state.begin(), state.end());
  request.mutable_pending_inputs()->Add(pending_inputs.begin(), pending_inputs.end());
  return Unary(&v1::ExplorationService::Stub::PlanInputs, request, session,
               options_.plan_deadline, Resend::kAfterLostAnswer);
}

template <typename Request, typename Response>
absl::StatusOr<Response> ExciteClient::Unary(
    grpc::Status (v1::ExplorationService::Stub::*method)(grpc::ClientContext*,
                                                         const Request&, Response*),
    const Request& request, const std::string& session, std::chrono::milliseconds timeout,
    Resend resend) {
  return Retrying(
      [&]() -> absl::StatusOr<Response> {
        grpc::ClientContext context;
        Prepare(&context, timeout, session);
        Response response;
        if (absl::Status s =
                FromGrpc((stub_.get()->*method)(&context, request, &response));
            !s.ok()) {
          return s;
        }
        return response;
      },
      resend);
}

absl::StatusOr<v1::SessionArchive> ExciteClient::ExportSession(const std::string& name) {
  v1::ExportSessionRequest request;
  request.set_name(name);
  absl::StatusOr<v1::SessionArchive> archive =
      Unary(&v1::ExplorationService::Stub::ExportSession, request, name,
            options_.default_deadline, Resend::kAfterLostAnswer);
  if (!archive.ok()) {
    return WithSizeHint(archive.status(),
                        absl::StrCat("the archive is larger than this client's message "
                                     "limit of ",
                                     options_.max_message_mb, " MiB (--max_message_mb)"));
  }
  return archive;
}

absl::StatusOr<v1::Session> ExciteClient::ImportSession(const v1::SessionArchive& archive,
                                                        const std::string& session_id) {
  v1::ImportSessionRequest request;
  *request.mutable_archive() = archive;
  request.set_session_id(session_id);
  absl::StatusOr<v1::Session> session =
      Unary(&v1::ExplorationService::Stub::ImportSession, request,
            session_id.empty() ? archive.session_id() : session_id,
            options_.default_deadline, Resend::kIfUnavailable);
  if (!session.ok()) {
    return WithSizeHint(
        session.status(),
        absl::StrCat("the archive (", request.ByteSizeLong(),
                     " bytes) is larger than the message limit of the server (its "
                     "--max_message_mb) or of this client (",
                     options_.max_message_mb, " MiB, --max_message_mb): raise it"));
  }
  return session;
}

absl::Status WriteSessionArchiveFile(const std::string& path,
                                     const v1::SessionArchive& archive) {
  const std::string tmp = absl::StrCat(path, ".tmp");
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out || !archive.SerializeToOstream(&out) || !out.flush()) {
      std::remove(tmp.c_str());
      return absl::UnavailableError(absl::StrCat("cannot write ", tmp));
    }
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::remove(tmp.c_str());
    return absl::UnavailableError(absl::StrCat("cannot rename ", tmp, " to ", path));
  }
  return absl::OkStatus();
}

absl::StatusOr<v1::SessionArchive> ReadSessionArchiveFile(const std::string& path) {
  std::string bytes;
  if (!ReadFile(path, &bytes)) {
    return absl::InvalidArgumentError(absl::StrCat("cannot read ", path));
  }
  v1::SessionArchive archive;
  if (!archive.ParseFromString(bytes) || archive.format_version() == 0) {
    return absl::InvalidArgumentError(absl::StrCat(
        path, " is not a session archive (a file written by excite export)"));
  }
  return archive;
}

}  // namespace excite::client
