#include "server/service/auth.h"

#include <algorithm>
#include <fstream>
#include <sstream>
#include <utility>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/strip.h"
#include "grpcpp/security/auth_metadata_processor.h"

namespace excite::service {
namespace {

constexpr absl::string_view kHealthPrefix = "/grpc.health.v1.Health/";

// Equality in time independent of where the strings differ.
bool ConstantTimeEquals(absl::string_view a, absl::string_view b) {
  unsigned char diff = a.size() == b.size() ? 0 : 1;
  const size_t n = std::min(a.size(), b.size());
  for (size_t i = 0; i < n; ++i) {
    diff |= static_cast<unsigned char>(a[i] ^ b[i]);
  }
  return diff == 0;
}

// Checks every call but health checks (so that probes need no secret): with
// `require_client_certificate`, that the TLS peer presented a certificate the
// client CA signed (the handshake verified it: it only asks for one, so that
// probes can connect without); with a non-empty `token`, that the call carries
// "authorization: Bearer <token>".
class CallAuthProcessor final : public grpc::AuthMetadataProcessor {
 public:
  CallAuthProcessor(std::string token, bool require_client_certificate)
      : token_(std::move(token)),
        require_client_certificate_(require_client_certificate) {}

  bool IsBlocking() const override { return false; }

  grpc::Status Process(const InputMetadata& auth_metadata, grpc::AuthContext* context,
                       OutputMetadata* consumed_auth_metadata,
                       OutputMetadata* /*response_metadata*/) override {
    const auto path = auth_metadata.find(":path");
    if (path != auth_metadata.end() &&
        absl::StartsWith(absl::string_view(path->second.data(), path->second.size()),
                         kHealthPrefix)) {
      return grpc::Status::OK;
    }
    if (require_client_certificate_ &&
        (context == nullptr || context->FindPropertyValues("x509_pem_cert").empty())) {
      return grpc::Status(grpc::StatusCode::UNAUTHENTICATED,
                          "this server requires a client certificate signed by its "
                          "client CA (mutual TLS); only health checks work without");
    }
    if (token_.empty()) return grpc::Status::OK;
    const auto header = auth_metadata.find("authorization");
    if (header == auth_metadata.end()) {
      return grpc::Status(grpc::StatusCode::UNAUTHENTICATED,
                          "missing \"authorization: Bearer <token>\" metadata");
    }
    absl::string_view value(header->second.data(), header->second.size());
    if (!absl::ConsumePrefix(&value, "Bearer ") || !ConstantTimeEquals(value, token_)) {
      return grpc::Status(grpc::StatusCode::UNAUTHENTICATED, "invalid bearer token");
    }
    consumed_auth_metadata->insert(
        std::make_pair(std::string(header->first.data(), header->first.size()),
                       std::string(header->second.data(), header->second.size())));
    return grpc::Status::OK;
  }

 private:
  const std::string token_;
  const bool require_client_certificate_;
};

absl::StatusOr<std::string> ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return absl::InvalidArgumentError(absl::StrCat("cannot read ", path));
  std::ostringstream contents;
  contents << in.rdbuf();
  return contents.str();
}

}  // namespace

bool IsLoopbackHost(const std::string& host) {
  return host == "localhost" || host == "::1" || absl::StartsWith(host, "127.");
}

absl::StatusOr<std::string> ReadSecretFile(const std::string& path) {
  absl::StatusOr<std::string> contents = ReadFile(path);
  if (!contents.ok()) return contents.status();
  std::string stripped(absl::StripAsciiWhitespace(*contents));
  if (stripped.empty())
    return absl::InvalidArgumentError(absl::StrCat(path, " is empty"));
  return stripped;
}

absl::StatusOr<std::shared_ptr<grpc::ServerCredentials>> MakeServerCredentials(
    const SecurityOptions& options, const std::string& host) {
  if (options.tls_cert_file.empty() != options.tls_key_file.empty()) {
    return absl::InvalidArgumentError("TLS needs both a certificate and a key file");
  }
  std::shared_ptr<grpc::ServerCredentials> credentials;
  if (!options.tls_cert_file.empty()) {
    absl::StatusOr<std::string> cert = ReadFile(options.tls_cert_file);
    if (!cert.ok()) return cert.status();
    absl::StatusOr<std::string> key = ReadFile(options.tls_key_file);
    if (!key.ok()) return key.status();
    grpc::SslServerCredentialsOptions ssl;
    ssl.pem_key_cert_pairs.push_back({*key, *cert});
    if (!options.tls_client_ca_file.empty()) {
      absl::StatusOr<std::string> ca = ReadFile(options.tls_client_ca_file);
      if (!ca.ok()) return ca.status();
      ssl.pem_root_certs = *ca;
      // Asked for and verified if presented, required per call by
      // CallAuthProcessor: health probes connect without one.
      ssl.client_certificate_request = GRPC_SSL_REQUEST_CLIENT_CERTIFICATE_AND_VERIFY;
    }
    credentials = grpc::SslServerCredentials(ssl);
  } else if (!options.tls_client_ca_file.empty()) {
    return absl::InvalidArgumentError("a client CA needs a server certificate and key");
  } else if (!options.auth_token.empty()) {
    if (!IsLoopbackHost(host)) {
      return absl::InvalidArgumentError(absl::StrCat(
          "a bearer token without TLS is only accepted on a loopback address, not on ",
          host, " (it would travel in clear text): add a certificate and key"));
    }
    credentials = grpc::experimental::LocalServerCredentials(LOCAL_TCP);
  } else {
    return grpc::InsecureServerCredentials();
  }
  const bool mutual_tls = !options.tls_client_ca_file.empty();
  if (!options.auth_token.empty() || mutual_tls) {
    credentials->SetAuthMetadataProcessor(
        std::make_shared<CallAuthProcessor>(options.auth_token, mutual_tls));
  }
  return credentials;
}

}  // namespace excite::service
