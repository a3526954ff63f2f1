#ifndef EXCITE_CLIENT_EXCITE_CLIENT_H_
#define EXCITE_CLIENT_EXCITE_CLIENT_H_

#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "excite/v1/exploration_service.grpc.pb.h"

namespace excite::client {

struct ClientOptions {
  // Deadline of each call unless a call says otherwise.
  std::chrono::milliseconds default_deadline{30000};
  // Deadline of PlanInputs (solves can take a while).
  std::chrono::milliseconds plan_deadline{60000};
  // Deadline of one AddData attempt. Storing a batch takes milliseconds; an
  // attempt that runs this long is taken as stuck (a replica that died with the
  // call in flight, behind a proxy that never saw it go) and is retried like an
  // UNAVAILABLE one, within retry_unavailable.
  std::chrono::milliseconds data_deadline{30000};
  // TLS: PEM CA bundle that signed the server's certificate; empty: plaintext.
  std::string tls_ca_file;
  // Mutual TLS: this client's PEM certificate and key (with tls_ca_file).
  std::string tls_cert_file;
  std::string tls_key_file;
  // Sent as "authorization: Bearer <auth_token>" on every call if non-empty.
  std::string auth_token;
  // Largest message this client sends or receives, in MiB (the server's default
  // --max_message_mb). ExportSession / ImportSession of a big session may need
  // more here and on the server.
  int max_message_mb = 64;
  // Calls that fail with UNAVAILABLE (no server reachable, a replica draining or
  // dead, a session moving to another replica) are retried, with backoff from
  // 50 ms to 2 s, until this much time has passed since the first attempt; 0:
  // never. Safe for AddData (sequence numbers make a resent batch a
  // duplicate), which is also retried after DEADLINE_EXCEEDED (data_deadline).
  // Reads, PlanInputs and AddData are also retried after a lost answer (UNKNOWN
  // "Stream removed": a proxy's replica died mid-call); a CreateSession without an id
  // that failed after the server stored it leaves an unused session behind. DataStream is
  // not retried.
  std::chrono::milliseconds retry_unavailable{0};
};

// The request header naming the session a call is about: its id
// ("x-excite-session: {id}"). Every session call of this client and of the Python
// client carries it, so that a proxy in front of several replicas can route all
// calls of a session to one replica (deploy/haproxy).
inline constexpr char kSessionHeader[] = "x-excite-session";

// Reads the client's auth token: the file `token_file` if non-empty (whitespace
// stripped), else $EXCITE_AUTH_TOKEN, else "". INVALID_ARGUMENT if the file
// cannot be read.
absl::StatusOr<std::string> LoadAuthToken(const std::string& token_file);

// A channel to `target` ("host:port") with the TLS settings of `options` and
// message caps of options.max_message_mb (default 64 MiB, the server's).
// Plaintext unless options.tls_ca_file is set; a TLS file that cannot be read
// gives a channel on which every call fails with UNAVAILABLE.
std::shared_ptr<grpc::Channel> CreateChannel(const std::string& target,
                                             const ClientOptions& options);

// One StreamData stream to a session: each Send() writes one message and waits
// for its acknowledgement, so a caller always knows what is stored: every batch
// whose Send() returned OK. Not thread-safe. Once a Send() fails the stream is
// over: its status says why (the server's error, or UNAVAILABLE / CANCELLED /
// DEADLINE_EXCEEDED for a broken stream), and the unacknowledged batch may or
// may not be stored: resend it on a new stream (sequence numbers make that safe).
class DataStream {
 public:
  ~DataStream();
  DataStream(const DataStream&) = delete;
  DataStream& operator=(const DataStream&) = delete;

  absl::StatusOr<v1::AddDataAck> Send(const std::vector<v1::Transition>& batch);
  // Closes the stream; OK if the server ended it cleanly.
  absl::Status Close();

 private:
  friend class ExciteClient;
  DataStream() = default;

  std::string session_;
  grpc::ClientContext context_;
  std::unique_ptr<grpc::ClientReaderWriter<v1::AddDataRequest, v1::AddDataAck>> stream_;
  absl::Status finished_;  // set once the stream ended
  bool done_ = false;
};

// A thin synchronous wrapper over ExplorationService stubs: sets deadlines and
// turns grpc::Status into absl::Status (same code, same message). Thread-safe.
class ExciteClient {
 public:
  // `target` is "host:port"; the channel is CreateChannel(target, options).
  static std::unique_ptr<ExciteClient> Connect(const std::string& target,
                                               ClientOptions options = {});
  // Waits until the channel is ready or the timeout passes (UNAVAILABLE).
  absl::Status WaitForReady(std::chrono::milliseconds timeout);

  absl::StatusOr<v1::Session> CreateSession(const v1::SessionConfig& config,
                                            const std::string& session_id = "");
  // With everything CreateSessionRequest holds (display name, labels).
  absl::StatusOr<v1::Session> CreateSession(const v1::CreateSessionRequest& request);
  absl::StatusOr<v1::Session> GetSession(const std::string& name);
  // The model rolled forward along an input sequence (Rollout).
  absl::StatusOr<v1::RolloutResponse> Rollout(const v1::RolloutRequest& request);
  // The session's fitted model as a model file (ExportModel; read it with
  // excite::LoadedModel, model_file/loaded_model.h).
  absl::StatusOr<v1::ExportModelResponse> ExportModel(const std::string& name);
  // The session's plans, batch errors and mean std so far (GetSessionHistory).
  absl::StatusOr<v1::SessionHistory> GetSessionHistory(const std::string& name);
  // `filter` as in ListSessionsRequest.filter (empty: every session).
  absl::StatusOr<v1::ListSessionsResponse> ListSessions(int page_size,
                                                        const std::string& page_token,
                                                        const std::string& filter = "");
  absl::Status DeleteSession(const std::string& name);
  // One stream carrying `batches` as consecutive messages.
  absl::StatusOr<v1::AddDataResponse> AddData(
      const std::string& session,
      const std::vector<std::vector<v1::Transition>>& batches);
  // A StreamData stream to `session` ("sessions/{id}"), acknowledged message by
  // message; `deadline` bounds the whole stream (none by default: streams of a
  // plant may run for hours).
  std::unique_ptr<DataStream> OpenDataStream(
      const std::string& session,
      std::chrono::milliseconds deadline = std::chrono::hours(24 * 365));
  absl::StatusOr<v1::PredictResponse> Predict(const v1::PredictRequest& request);
  // `pending_inputs`: row-major, the inputs the plant applies from `state` before
  // the plan starts (PlanInputsRequest.pending_inputs); empty for none.
  absl::StatusOr<v1::PlanInputsResponse> PlanInputs(
      const std::string& session, const std::vector<double>& state,
      const std::vector<double>& pending_inputs = {});
  // The session "sessions/{id}" as a self-contained archive (see
  // WriteSessionArchiveFile).
  absl::StatusOr<v1::SessionArchive> ExportSession(const std::string& name);
  // A new session from `archive`, under `session_id` if non-empty (else the
  // archive's id). A RESOURCE_EXHAUSTED from a message-size limit says which
  // limit to raise.
  absl::StatusOr<v1::Session> ImportSession(const v1::SessionArchive& archive,
                                            const std::string& session_id = "");

 private:
  ExciteClient(std::shared_ptr<grpc::Channel> channel, ClientOptions options);
  // Deadline, the authorization metadata and, unless empty, the session header.
  void Prepare(grpc::ClientContext* context, std::chrono::milliseconds timeout,
               const std::string& session) const;
  // Which failures besides UNAVAILABLE a call is resent after. A lost answer
  // is gRPC's UNKNOWN "Stream removed": the connection (a proxy's to a replica
  // that died) dropped mid-call, so the work may or may not have been done.
  enum class Resend {
    kIfUnavailable,              // resending could do the work twice
    kAfterLostAnswer,            // reads, and plans: doing it again changes nothing
    kAfterLostAnswerOrDeadline,  // AddData: sequence numbers make a resent batch a
                                 // duplicate
  };
  // `attempt` (one call, returning absl::Status or StatusOr), retried as
  // options_.retry_unavailable and `resend` say.
  template <typename Attempt>
  auto Retrying(Attempt&& attempt, Resend resend) const -> decltype(attempt());
  // One unary call of `method` about `session` ("" if none), with `timeout`.
  template <typename Request, typename Response>
  absl::StatusOr<Response> Unary(grpc::Status (v1::ExplorationService::Stub::*method)(
                                     grpc::ClientContext*, const Request&, Response*),
                                 const Request& request, const std::string& session,
                                 std::chrono::milliseconds timeout, Resend resend);
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<v1::ExplorationService::Stub> stub_;
  ClientOptions options_;
};

// The file format of `excite export` / `excite import`: the binary serialized
// SessionArchive, nothing around it. Write replaces `path` atomically (a
// temporary file in the same directory, renamed). Read: INVALID_ARGUMENT if the
// file is not an archive (does not parse, or has no format_version).
absl::Status WriteSessionArchiveFile(const std::string& path,
                                     const v1::SessionArchive& archive);
absl::StatusOr<v1::SessionArchive> ReadSessionArchiveFile(const std::string& path);

}  // namespace excite::client

#endif  // EXCITE_CLIENT_EXCITE_CLIENT_H_
