#ifndef EXCITE_SERVER_WEB_WEB_VIEW_H_
#define EXCITE_SERVER_WEB_WEB_VIEW_H_

#include <memory>
#include <string>
#include <thread>

#include "absl/status/statusor.h"
#include "grpcpp/channel.h"

namespace httplib {
class Server;
}

namespace excite::web {

struct WebViewOptions {
  // HOST:PORT (port 0: any free one); IPv4 hosts or "localhost".
  std::string listen;
  // As the API's: with a certificate the page is served over HTTPS, with a client
  // CA only to browsers presenting a certificate it signed.
  std::string tls_cert_file;
  std::string tls_key_file;
  std::string tls_client_ca_file;
  // If non-empty, every /api/ request must carry "Authorization: Bearer <token>"
  // (the page reads it from its URL's #token=... fragment, which browsers never
  // send to a server, or asks for it).
  std::string auth_token;
};

// The live view of excite-server: a page (embedded in the binary, no external
// scripts) listing the sessions and showing one of them as it explores, and the
// JSON API it reads, a translation of ExplorationService calls made through
// `channel` (the server's in-process channel):
//   GET  /api/sessions[?filter=F]      ListSessions (every page)
//   GET  /api/sessions/ID              GetSession (with the last plan)
//   GET  /api/sessions/ID/history      GetSessionHistory (plans, learning curve)
//   GET  /api/sessions/ID/archive      ExportSession (samples with timestamps)
//   POST /api/sessions/ID/predict      Predict; body: a PredictRequest as JSON
//   POST /api/sessions/ID/rollout      Rollout; body: a RolloutRequest as JSON
// in protobuf's JSON mapping. Errors: {"code": "NOT_FOUND", "message": ...} with
// the HTTP status of Google's API mapping (400, 401, 404, 429, 503, ...).
// cpp-httplib (Debian's libcpp-httplib) with a pool of worker threads.
class WebView {
 public:
  // UNAVAILABLE if it cannot listen, INVALID_ARGUMENT for a bad address or
  // unreadable TLS files.
  static absl::StatusOr<std::unique_ptr<WebView>> Start(
      const WebViewOptions& options, std::shared_ptr<grpc::Channel> channel);
  // Stops serving and joins the listener.
  ~WebView();
  WebView(const WebView&) = delete;
  WebView& operator=(const WebView&) = delete;

  int port() const { return port_; }

 private:
  WebView() = default;

  std::unique_ptr<httplib::Server> http_;
  std::thread listener_;
  int port_ = 0;
};

}  // namespace excite::web

#endif  // EXCITE_SERVER_WEB_WEB_VIEW_H_
