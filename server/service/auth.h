#ifndef EXCITE_SERVER_SERVICE_AUTH_H_
#define EXCITE_SERVER_SERVICE_AUTH_H_

#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "grpcpp/security/server_credentials.h"

namespace excite::service {

// Transport security and the bearer-token check of excite-server.
struct SecurityOptions {
  // PEM files. Both or neither; with them the port speaks TLS.
  std::string tls_cert_file;
  std::string tls_key_file;
  // PEM CA bundle: if set, clients must present a certificate it signed (mTLS).
  std::string tls_client_ca_file;
  // If non-empty, every call except grpc.health.v1.Health/* must carry the
  // metadata "authorization: Bearer <auth_token>" (else UNAUTHENTICATED).
  std::string auth_token;
};

// The credentials of the listening port for `host` (the listen address's host):
//  - TLS (optionally mutual) if a certificate is given;
//  - else, with a token, local (loopback-only) credentials: a bearer token is
//    only accepted in plaintext over loopback; INVALID_ARGUMENT elsewhere;
//  - else plaintext.
// A token is checked by an AuthMetadataProcessor installed on the credentials.
// Files that cannot be read: INVALID_ARGUMENT.
absl::StatusOr<std::shared_ptr<grpc::ServerCredentials>> MakeServerCredentials(
    const SecurityOptions& options, const std::string& host);

// True for "localhost", 127.0.0.0/8 and ::1.
bool IsLoopbackHost(const std::string& host);

// The whole file, surrounding whitespace stripped; INVALID_ARGUMENT if it
// cannot be read or is empty after stripping.
absl::StatusOr<std::string> ReadSecretFile(const std::string& path);

}  // namespace excite::service

#endif  // EXCITE_SERVER_SERVICE_AUTH_H_
