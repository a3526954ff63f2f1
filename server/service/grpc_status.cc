#include "server/service/grpc_status.h"

#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "google/rpc/error_details.pb.h"
#include "google/rpc/status.pb.h"
#include "server/service/field_violation.h"

namespace excite::service {

grpc::Status ToGrpcStatus(const absl::Status& status) {
  if (status.ok()) return grpc::Status::OK;
  const int code = static_cast<int>(status.code());
  const grpc::StatusCode grpc_code = code >= 1 && code <= 16
                                         ? static_cast<grpc::StatusCode>(code)
                                         : grpc::StatusCode::UNKNOWN;
  std::string message(status.message());
  const std::vector<FieldViolation> violations = FieldViolations(status);
  if (violations.empty()) return grpc::Status(grpc_code, message);

  google::rpc::BadRequest bad_request;
  for (const FieldViolation& v : violations) {
    google::rpc::BadRequest::FieldViolation* violation =
        bad_request.add_field_violations();
    violation->set_field(v.field);
    violation->set_description(v.description);
  }
  google::rpc::Status details;
  details.set_code(static_cast<int>(grpc_code));
  details.set_message(message);
  details.add_details()->PackFrom(bad_request);
  return grpc::Status(grpc_code, message, details.SerializeAsString());
}

}  // namespace excite::service
