#ifndef EXCITE_SERVER_SERVICE_GRPC_STATUS_H_
#define EXCITE_SERVER_SERVICE_GRPC_STATUS_H_

#include "absl/status/status.h"
#include "grpcpp/support/status.h"

namespace excite::service {

// Same code (the numeric values of absl::StatusCode and grpc::StatusCode agree),
// same message. A status carrying a field path (FieldViolationError) also gets
// binary error details: a serialized google.rpc.Status (same code and message)
// whose details hold one google.rpc.BadRequest naming the field, sent by gRPC
// as the grpc-status-details-bin trailer.
grpc::Status ToGrpcStatus(const absl::Status& status);

}  // namespace excite::service

#endif  // EXCITE_SERVER_SERVICE_GRPC_STATUS_H_
