#ifndef EXCITE_SERVER_SERVICE_GRPC_STATUS_H_
#define EXCITE_SERVER_SERVICE_GRPC_STATUS_H_

#include "absl/status/status.h"
#include "grpcpp/support/status.h"

namespace excite::service {

// Same code (the numeric values of absl::StatusCode and grpc::StatusCode agree),
// same message up to 768 bytes (longer ones are cut, saying by how much). A
// status carrying field paths (FieldViolationError, Violations) also gets
// binary error details: a serialized google.rpc.Status (same code and message)
// whose details hold one google.rpc.BadRequest with the first of its field
// violations (at most 10, each field and description cut to 200 bytes), sent by
// gRPC as the grpc-status-details-bin trailer. So no request, however bad, gets
// an error too large for a client's metadata limit.
grpc::Status ToGrpcStatus(const absl::Status& status);

}  // namespace excite::service

#endif  // EXCITE_SERVER_SERVICE_GRPC_STATUS_H_
