#include "server/service/grpc_status.h"

#include <optional>
#include <string>

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
  const std::optional<std::string> field = ViolatedField(status);
  if (!field.has_value()) return grpc::Status(grpc_code, message);

  google::rpc::BadRequest bad_request;
  google::rpc::BadRequest::FieldViolation* violation = bad_request.add_field_violations();
  violation->set_field(*field);
  // The description is the message after "<field>: " when it has that form.
  const std::string prefix = absl::StrCat(*field, ": ");
  const size_t at = message.find(prefix);
  violation->set_description(
      at == std::string::npos ? message : message.substr(at + prefix.size()));
  google::rpc::Status details;
  details.set_code(static_cast<int>(grpc_code));
  details.set_message(message);
  details.add_details()->PackFrom(bad_request);
  return grpc::Status(grpc_code, message, details.SerializeAsString());
}

}  // namespace excite::service
