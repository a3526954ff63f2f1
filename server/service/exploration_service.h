#ifndef EXCITE_SERVER_SERVICE_EXPLORATION_SERVICE_H_
#define EXCITE_SERVER_SERVICE_EXPLORATION_SERVICE_H_

#include <cstdint>
#include <memory>
#include <string>

#include "absl/base/thread_annotations.h"
#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"
#include "excite/v1/exploration_service.grpc.pb.h"
#include "server/service/config_validation.h"
#include "server/session/session_registry.h"

namespace excite::service {

using session::Session;
using session::SessionRegistry;

// Caps of what one request or session may ask (RESOURCE_EXHAUSTED beyond).
struct ServiceLimits {
  int64_t max_sessions = 10000;
  // Exact GPs cost O(n^2) memory and O(n^3) per refit: beyond this, use fewer.
  int64_t max_samples_per_session = 20000;
  int64_t max_predict_points = 100000;
  // Largest SessionConfig.horizon (after defaults) a new session may have
  // (--max_horizon may lower it; config validation never allows more).
  int32_t max_horizon = kMaxHorizon;
  // Largest message sent or received (ServerOptions.max_message_mb, set by
  // ExciteServer): an ExportSession archive beyond it is RESOURCE_EXHAUSTED.
  int64_t max_message_bytes = int64_t{64} * 1024 * 1024;
};

// The synchronous gRPC service: translates requests into session calls and
// absl::Status into grpc::Status. Every RPC is logged at debug level (method,
// session, status, ms). No exception escapes an RPC. Thread-safe.
//
// Draining: after StartDraining() new RPCs fail with UNAVAILABLE while those in
// flight finish; WaitIdle() waits for them. (grpc::Server::Shutdown alone waits
// for the whole grace period whenever a client keeps an idle connection open.)
class ExplorationService final : public v1::ExplorationService::Service {
 public:
  // `registry` must outlive the service.
  ExplorationService(SessionRegistry* registry, ServiceLimits limits);

  grpc::Status CreateSession(grpc::ServerContext* context,
                             const v1::CreateSessionRequest* request,
                             v1::Session* response) override;
  grpc::Status GetSession(grpc::ServerContext* context,
                          const v1::GetSessionRequest* request,
                          v1::Session* response) override;
  grpc::Status Rollout(grpc::ServerContext* context, const v1::RolloutRequest* request,
                       v1::RolloutResponse* response) override;
  grpc::Status ExportModel(grpc::ServerContext* context,
                           const v1::ExportModelRequest* request,
                           v1::ExportModelResponse* response) override;
  grpc::Status GetSessionHistory(grpc::ServerContext* context,
                                 const v1::GetSessionHistoryRequest* request,
                                 v1::SessionHistory* response) override;
  grpc::Status ListSessions(grpc::ServerContext* context,
                            const v1::ListSessionsRequest* request,
                            v1::ListSessionsResponse* response) override;
  grpc::Status DeleteSession(grpc::ServerContext* context,
                             const v1::DeleteSessionRequest* request,
                             v1::DeleteSessionResponse* response) override;
  grpc::Status AddData(grpc::ServerContext* context,
                       grpc::ServerReader<v1::AddDataRequest>* reader,
                       v1::AddDataResponse* response) override;
  grpc::Status StreamData(
      grpc::ServerContext* context,
      grpc::ServerReaderWriter<v1::AddDataAck, v1::AddDataRequest>* stream) override;
  grpc::Status Predict(grpc::ServerContext* context, const v1::PredictRequest* request,
                       v1::PredictResponse* response) override;
  grpc::Status PlanInputs(grpc::ServerContext* context,
                          const v1::PlanInputsRequest* request,
                          v1::PlanInputsResponse* response) override;
  grpc::Status ExportSession(grpc::ServerContext* context,
                             const v1::ExportSessionRequest* request,
                             v1::SessionArchive* response) override;
  grpc::Status ImportSession(grpc::ServerContext* context,
                             const v1::ImportSessionRequest* request,
                             v1::Session* response) override;

  // New RPCs get UNAVAILABLE from now on.
  void StartDraining();
  // Waits until no RPC is in flight or `timeout` passed; true if idle.
  bool WaitIdle(absl::Duration timeout);
  // True once StartDraining() was called.
  bool Draining() const;

 private:
  // Runs one RPC body: refuses it while draining, counts it in flight, catches
  // anything thrown, logs one debug line, converts the status.
  template <typename Body>
  grpc::Status RunRpc(absl::string_view method, const std::string& session, Body&& body);
  // The session named `name` ("sessions/{id}"; INVALID_ARGUMENT naming `field`
  // if malformed, NOT_FOUND if unknown).
  absl::StatusOr<std::shared_ptr<Session>> FindSession(const std::string& name,
                                                       absl::string_view field);
  // FindSession, then DATA_LOSS if the session was set aside as damaged: checked
  // before a request is validated against dimensions a damaged session may not
  // have.
  absl::StatusOr<std::shared_ptr<Session>> FindUndamagedSession(const std::string& name,
                                                                absl::string_view field);
  // One message of an AddData or StreamData stream: on the first, finds the
  // session into *session; then validates the message and stores it
  // (Session::AddSamples, whose result counts this message). INVALID_ARGUMENT
  // names "message {index}".
  absl::StatusOr<v1::AddDataResponse> AddMessage(const v1::AddDataRequest& request,
                                                 int64_t message_index,
                                                 std::shared_ptr<Session>* session);
  // RESOURCE_EXHAUSTED naming `field` if a validated config's horizon exceeds
  // limits_.max_horizon.
  absl::Status CheckHorizonCap(const v1::SessionConfig& validated,
                               absl::string_view field) const;

  mutable absl::Mutex mu_;
  bool draining_ ABSL_GUARDED_BY(mu_) = false;
  int64_t in_flight_ ABSL_GUARDED_BY(mu_) = 0;

  SessionRegistry* const registry_;
  const ServiceLimits limits_;
};

}  // namespace excite::service

#endif  // EXCITE_SERVER_SERVICE_EXPLORATION_SERVICE_H_
