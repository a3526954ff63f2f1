#include "server/service/grpc_status.h"

#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"
#include "google/rpc/error_details.pb.h"
#include "google/rpc/status.pb.h"
#include "server/service/field_violation.h"

namespace excite::service {
namespace {

// A client refuses a reply whose metadata exceeds its limit (gRPC's default is
// 8 KiB) and reports RESOURCE_EXHAUSTED instead of our status. The message
// travels twice: as grpc-message (percent-encoded, up to 3 bytes per byte) and
// inside grpc-status-details-bin (base64, 4 per 3). With these caps the two
// stay under 5.5 KiB whatever the request held (1000 bad labels, an 18 KB
// filter quoted back).
constexpr size_t kMaxMessageBytes = 768;
constexpr size_t kMaxViolationTextBytes = 200;  // a field path or a description
constexpr size_t kMaxBadRequestBytes = 1536;
constexpr int kMaxFieldViolations = 10;

// `text` cut at a UTF-8 character boundary to at most `max` bytes, saying how
// many were cut.
std::string Capped(absl::string_view text, size_t max) {
  if (text.size() <= max) return std::string(text);
  size_t cut = max;
  while (cut > 0 && (static_cast<unsigned char>(text[cut]) & 0xC0) == 0x80) --cut;
  return absl::StrCat(text.substr(0, cut), " ... (", text.size() - cut, " more bytes)");
}

}  // namespace

grpc::Status ToGrpcStatus(const absl::Status& status) {
  if (status.ok()) return grpc::Status::OK;
  const int code = static_cast<int>(status.code());
  const grpc::StatusCode grpc_code = code >= 1 && code <= 16
                                         ? static_cast<grpc::StatusCode>(code)
                                         : grpc::StatusCode::UNKNOWN;
  const std::string message = Capped(status.message(), kMaxMessageBytes);
  const std::vector<FieldViolation> violations = FieldViolations(status);
  if (violations.empty()) return grpc::Status(grpc_code, message);

  google::rpc::BadRequest bad_request;
  for (const FieldViolation& v : violations) {
    google::rpc::BadRequest::FieldViolation violation;
    violation.set_field(Capped(v.field, kMaxViolationTextBytes));
    violation.set_description(Capped(v.description, kMaxViolationTextBytes));
    if (bad_request.field_violations_size() == kMaxFieldViolations ||
        bad_request.ByteSizeLong() + violation.ByteSizeLong() + 3 > kMaxBadRequestBytes) {
      break;  // the message counts the rest
    }
    *bad_request.add_field_violations() = std::move(violation);
  }
  google::rpc::Status details;
  details.set_code(static_cast<int>(grpc_code));
  details.set_message(message);
  details.add_details()->PackFrom(bad_request);
  return grpc::Status(grpc_code, message, details.SerializeAsString());
}

}  // namespace excite::service
