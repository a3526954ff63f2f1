// excite-health: asks a gRPC server for its grpc.health.v1 status.
//
//   excite-health [--server=HOST:PORT] [--service=NAME] [--timeout_s=S] [--wait_s=W]
//
// Prints the status (SERVING, NOT_SERVING, SERVICE_UNKNOWN, ...) or the error on one
// line. Exit status: 0 iff the status is SERVING, 1 otherwise (not serving, unknown
// service, unreachable, deadline exceeded), 2 on a usage error. With --wait_s it asks
// again every 0.5 s until the answer is SERVING or W seconds have passed.
//
// Container images have no grpc_health_probe (Debian does not package one), so the
// image's HEALTHCHECK, the CI smoke test and humans use this. Kubernetes uses its
// native grpc: probes instead. The health messages are tiny, so they are encoded here
// with protobuf's wire-format primitives over a generic stub: no health .proto needed.

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <future>
#include <string>
#include <thread>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/status/status.h"
#include "client/connection_flags.h"
#include "client/excite_client.h"
#include "common/usage.h"
#include "google/protobuf/io/coded_stream.h"
#include "google/protobuf/io/zero_copy_stream_impl_lite.h"
#include "google/protobuf/wire_format_lite.h"
#include "grpcpp/channel.h"
#include "grpcpp/generic/generic_stub.h"
#include "grpcpp/support/byte_buffer.h"

ABSL_FLAG(std::string, server, "127.0.0.1:50051", "Server address, HOST:PORT.");
ABSL_FLAG(std::string, service, "",
          "Service name to ask about; empty (default) asks about the whole server.");
ABSL_FLAG(double, timeout_s, 3.0, "Deadline of each Check call in seconds.");
ABSL_FLAG(double, wait_s, 0.0,
          "Keep asking every 0.5 s until SERVING or this many seconds passed (0: ask "
          "once).");

namespace {

using google::protobuf::internal::WireFormatLite;

constexpr char kCheckMethod[] = "/grpc.health.v1.Health/Check";

// grpc.health.v1.HealthCheckResponse.ServingStatus.
const char* StatusName(uint32_t status) {
  switch (status) {
    case 0:
      return "UNKNOWN";
    case 1:
      return "SERVING";
    case 2:
      return "NOT_SERVING";
    case 3:
      return "SERVICE_UNKNOWN";
    default:
      return "UNRECOGNISED_STATUS";
  }
}

// HealthCheckRequest { string service = 1; } in wire format.
std::string EncodeRequest(const std::string& service) {
  std::string bytes;
  {
    google::protobuf::io::StringOutputStream raw(&bytes);
    google::protobuf::io::CodedOutputStream out(&raw);
    if (!service.empty()) WireFormatLite::WriteString(1, service, &out);
  }
  return bytes;
}

// HealthCheckResponse { ServingStatus status = 1; }: the status, or false if the
// bytes are not such a message. A missing field means 0 (UNKNOWN), as in proto3.
bool DecodeResponse(const std::string& bytes, uint32_t* status) {
  *status = 0;
  google::protobuf::io::CodedInputStream in(
      reinterpret_cast<const uint8_t*>(bytes.data()), static_cast<int>(bytes.size()));
  while (true) {
    const uint32_t tag = in.ReadTag();
    if (tag == 0) return in.ConsumedEntireMessage();  // end of input, or a bad tag
    if (tag == WireFormatLite::MakeTag(1, WireFormatLite::WIRETYPE_VARINT)) {
      if (!in.ReadVarint32(status)) return false;
    } else if (!WireFormatLite::SkipField(&in, tag)) {
      return false;
    }
  }
}

std::string ToString(const grpc::ByteBuffer& buffer) {
  std::vector<grpc::Slice> slices;
  std::string out;
  if (!buffer.Dump(&slices).ok()) return out;
  for (const grpc::Slice& slice : slices) {
    out.append(reinterpret_cast<const char*>(slice.begin()), slice.size());
  }
  return out;
}

// One Check call. Returns true iff SERVING; `line` says what happened.
bool CheckOnce(grpc::GenericStub& stub, const std::string& request_bytes,
               double timeout_s, std::string* line) {
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() +
                       std::chrono::milliseconds(static_cast<int64_t>(timeout_s * 1000)));
  grpc::Slice slice(request_bytes);
  grpc::ByteBuffer request(&slice, 1);
  grpc::ByteBuffer response;
  std::promise<grpc::Status> done;
  stub.UnaryCall(&context, kCheckMethod, grpc::StubOptions(), &request, &response,
                 [&done](grpc::Status status) { done.set_value(std::move(status)); });
  const grpc::Status status = done.get_future().get();
  if (!status.ok()) {
    *line = std::string("error: ") +
            absl::StatusCodeToString(static_cast<absl::StatusCode>(status.error_code())) +
            ": " + status.error_message();
    return false;
  }
  uint32_t serving = 0;
  if (!DecodeResponse(ToString(response), &serving)) {
    *line = "error: malformed HealthCheckResponse";
    return false;
  }
  *line = StatusName(serving);
  return serving == 1;
}

int Run() {
  const double timeout_s = absl::GetFlag(FLAGS_timeout_s);
  const double wait_s = absl::GetFlag(FLAGS_wait_s);
  if (!(timeout_s > 0) || !(wait_s >= 0)) {
    std::fprintf(stderr, "excite-health: --timeout_s must be > 0 and --wait_s >= 0\n");
    return 2;
  }
  const std::string server = absl::GetFlag(FLAGS_server);
  // TLS flags as for every client; the health service needs no token.
  excite::client::ClientOptions options;
  if (absl::Status s = excite::client::ApplyConnectionFlags(&options); !s.ok()) {
    std::fprintf(stderr, "excite-health: %s\n", std::string(s.message()).c_str());
    return 2;
  }
  const std::shared_ptr<grpc::ChannelInterface> channel =
      excite::client::CreateChannel(server, options);
  grpc::GenericStub stub(channel);
  const std::string request = EncodeRequest(absl::GetFlag(FLAGS_service));
  const auto give_up = std::chrono::steady_clock::now() +
                       std::chrono::milliseconds(static_cast<int64_t>(wait_s * 1000));
  std::string line;
  while (true) {
    if (CheckOnce(stub, request, timeout_s, &line)) {
      std::printf("%s\n", line.c_str());
      return 0;
    }
    if (std::chrono::steady_clock::now() + std::chrono::milliseconds(500) > give_up)
      break;
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
  }
  std::printf("%s\n", line.c_str());
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<char*> rest = excite::ParseFlags(
      argc, argv,
      "Exit 0 iff the server's grpc.health.v1 status is SERVING.\n"
      "  excite-health [--server=HOST:PORT] [--service=NAME] [--timeout_s=S] "
      "[--wait_s=W] [--tls_ca=PEM [--tls_client_cert=PEM --tls_client_key=PEM]]");
  if (rest.size() > 1) {
    std::fprintf(stderr, "excite-health: unexpected argument %s\n", rest[1]);
    return 2;
  }
  return Run();
}
