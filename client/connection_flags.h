#ifndef EXCITE_CLIENT_CONNECTION_FLAGS_H_
#define EXCITE_CLIENT_CONNECTION_FLAGS_H_

#include "absl/status/status.h"
#include "client/excite_client.h"

namespace excite::client {

// The connection flags every command-line client shares (excite, excite-sim,
// excite-health), defined once here:
//   --tls_ca           PEM CA bundle of the server's certificate: TLS on
//   --tls_client_cert  mutual TLS: this client's PEM certificate
//   --tls_client_key   mutual TLS: this client's PEM private key
//   --auth_token_file  bearer token file (default: $EXCITE_AUTH_TOKEN)
// Copies them into `options`. INVALID_ARGUMENT (a message naming the flag) if the
// token file cannot be read, or a client certificate or key comes without the
// other or without --tls_ca.
absl::Status ApplyConnectionFlags(ClientOptions* options);

}  // namespace excite::client

#endif  // EXCITE_CLIENT_CONNECTION_FLAGS_H_
