#include "client/connection_flags.h"

#include <string>

#include "absl/flags/flag.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"

ABSL_FLAG(
    std::string, tls_ca, "",
    "PEM CA bundle of the server's certificate: connect with TLS (default: plaintext).");
ABSL_FLAG(std::string, tls_client_cert, "", "Mutual TLS: this client's PEM certificate.");
ABSL_FLAG(std::string, tls_client_key, "", "Mutual TLS: this client's PEM private key.");
ABSL_FLAG(std::string, auth_token_file, "",
          "File holding the server's bearer token (default: $EXCITE_AUTH_TOKEN).");

namespace excite::client {

absl::Status ApplyConnectionFlags(ClientOptions* options) {
  options->tls_ca_file = absl::GetFlag(FLAGS_tls_ca);
  options->tls_cert_file = absl::GetFlag(FLAGS_tls_client_cert);
  options->tls_key_file = absl::GetFlag(FLAGS_tls_client_key);
  if (options->tls_cert_file.empty() != options->tls_key_file.empty()) {
    return absl::InvalidArgumentError(
        "--tls_client_cert and --tls_client_key go together: give both or neither");
  }
  if (!options->tls_cert_file.empty() && options->tls_ca_file.empty()) {
    return absl::InvalidArgumentError(
        "--tls_client_cert needs --tls_ca (mutual TLS runs over TLS)");
  }
  absl::StatusOr<std::string> token = LoadAuthToken(absl::GetFlag(FLAGS_auth_token_file));
  if (!token.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat("--auth_token_file: ", token.status().message()));
  }
  options->auth_token = *std::move(token);
  return absl::OkStatus();
}

}  // namespace excite::client
