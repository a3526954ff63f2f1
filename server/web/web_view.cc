#include "server/web/web_view.h"

#include <httplib.h>
#include <openssl/crypto.h>

#include <chrono>
#include <fstream>
#include <string>
#include <utility>

#include "absl/status/status.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "excite/v1/exploration_service.grpc.pb.h"
#include "google/protobuf/struct.pb.h"
#include "google/protobuf/util/json_util.h"
#include "grpcpp/client_context.h"
#include "server/web/web_assets.h"

namespace excite::web {
namespace {

constexpr auto kCallDeadline = std::chrono::seconds(30);
// Each of ListSessions' pages; the view lists at most this many pages.
constexpr int kPageSize = 1000;
constexpr int kMaxPages = 10;
constexpr char kJson[] = "application/json";

// Google's HTTP mapping of gRPC codes (google/rpc/code.proto).
int HttpStatus(grpc::StatusCode code) {
  switch (code) {
    case grpc::StatusCode::OK:
      return 200;
    case grpc::StatusCode::INVALID_ARGUMENT:
    case grpc::StatusCode::FAILED_PRECONDITION:
    case grpc::StatusCode::OUT_OF_RANGE:
      return 400;
    case grpc::StatusCode::UNAUTHENTICATED:
      return 401;
    case grpc::StatusCode::PERMISSION_DENIED:
      return 403;
    case grpc::StatusCode::NOT_FOUND:
      return 404;
    case grpc::StatusCode::ALREADY_EXISTS:
    case grpc::StatusCode::ABORTED:
      return 409;
    case grpc::StatusCode::RESOURCE_EXHAUSTED:
      return 429;
    case grpc::StatusCode::CANCELLED:
      return 499;
    case grpc::StatusCode::UNIMPLEMENTED:
      return 501;
    case grpc::StatusCode::UNAVAILABLE:
      return 503;
    case grpc::StatusCode::DEADLINE_EXCEEDED:
      return 504;
    default:
      return 500;
  }
}

std::string JsonString(const std::string& text) {
  std::string quoted;
  google::protobuf::util::JsonPrintOptions options;
  google::protobuf::Value value;
  value.set_string_value(text);
  (void)google::protobuf::util::MessageToJsonString(value, &quoted, options);
  return quoted;
}

void SendError(httplib::Response& res, grpc::StatusCode code,
               const std::string& message) {
  res.status = HttpStatus(code);
  res.set_content(
      absl::StrCat("{\"code\":\"",
                   absl::StatusCodeToString(static_cast<absl::StatusCode>(code)),
                   "\",\"message\":", JsonString(message), "}"),
      kJson);
}

void SendMessage(httplib::Response& res, const google::protobuf::Message& message) {
  google::protobuf::util::JsonPrintOptions options;
  options.preserve_proto_field_names = true;
  std::string json;
  options.always_print_primitive_fields = true;  // the page reads zeros too
  if (auto s = google::protobuf::util::MessageToJsonString(message, &json, options);
      !s.ok()) {
    SendError(res, grpc::StatusCode::INTERNAL, s.ToString());
    return;
  }
  res.status = 200;
  res.set_content(json, kJson);
}

// Compares in time independent of where the strings differ.
bool SameSecret(const std::string& a, const std::string& b) {
  return a.size() == b.size() && CRYPTO_memcmp(a.data(), b.data(), a.size()) == 0;
}

std::unique_ptr<grpc::ClientContext> CallContext() {
  auto context = std::make_unique<grpc::ClientContext>();
  context->set_deadline(std::chrono::system_clock::now() + kCallDeadline);
  return context;
}

bool Readable(const std::string& path) { return std::ifstream(path).good(); }

}  // namespace

absl::StatusOr<std::unique_ptr<WebView>> WebView::Start(
    const WebViewOptions& options, std::shared_ptr<grpc::Channel> channel) {
  const size_t colon = options.listen.rfind(':');
  int port = -1;
  if (colon == std::string::npos ||
      !absl::SimpleAtoi(options.listen.substr(colon + 1), &port) || port < 0 ||
      port > 65535) {
    return absl::InvalidArgumentError(
        absl::StrCat("web view address \"", options.listen, "\": want HOST:PORT"));
  }
  std::string host = options.listen.substr(0, colon);
  if (host == "localhost") host = "127.0.0.1";

  std::unique_ptr<WebView> view(new WebView());
  if (!options.tls_cert_file.empty()) {
    for (const std::string& file :
         {options.tls_cert_file, options.tls_key_file, options.tls_client_ca_file}) {
      if (!file.empty() && !Readable(file)) {
        return absl::InvalidArgumentError(absl::StrCat("web view: cannot read ", file));
      }
    }
    auto https = std::make_unique<httplib::SSLServer>(
        options.tls_cert_file.c_str(), options.tls_key_file.c_str(),
        options.tls_client_ca_file.empty() ? nullptr
                                           : options.tls_client_ca_file.c_str());
    if (!https->is_valid()) {
      return absl::InvalidArgumentError(
          "web view: the TLS certificate or key is not usable (PEM files that match?)");
    }
    view->http_ = std::move(https);
  } else {
    view->http_ = std::make_unique<httplib::Server>();
  }
  httplib::Server& http = *view->http_;
  // Four workers: a few slow browsers cannot starve the others.
  http.new_task_queue = [] { return new httplib::ThreadPool(4); };
  http.set_read_timeout(5, 0);
  http.set_write_timeout(30, 0);
  http.set_payload_max_length(8 << 20);
  http.set_default_headers({{"X-Content-Type-Options", "nosniff"},
                            {"Cache-Control", "no-store"},
                            {"Content-Security-Policy",
                             "default-src 'self'; img-src 'self' data:; "
                             "frame-ancestors 'none'"}});

  for (const WebAsset* asset = WebAssets(); !asset->path.empty(); ++asset) {
    const WebAsset a = *asset;
    http.Get(std::string(a.path), [a](const httplib::Request&, httplib::Response& res) {
      res.set_content(a.body.data(), a.body.size(), std::string(a.content_type).c_str());
    });
  }

  const std::string token = options.auth_token;
  // Every /api/ request is checked before its handler runs.
  http.set_pre_routing_handler(
      [token](const httplib::Request& req, httplib::Response& res) {
        if (token.empty() || !absl::StartsWith(req.path, "/api/")) {
          return httplib::Server::HandlerResponse::Unhandled;
        }
        const std::string header = req.get_header_value("Authorization");
        if (absl::StartsWith(header, "Bearer ") && SameSecret(header.substr(7), token)) {
          return httplib::Server::HandlerResponse::Unhandled;
        }
        SendError(res, grpc::StatusCode::UNAUTHENTICATED,
                  "send \"Authorization: Bearer <token>\" (open the page as "
                  "https://HOST:PORT/#token=<token>)");
        return httplib::Server::HandlerResponse::Handled;
      });

  auto stub = std::shared_ptr<v1::ExplorationService::Stub>(
      v1::ExplorationService::NewStub(std::move(channel)));
  auto fail = [](httplib::Response& res, const grpc::Status& status) {
    SendError(res, status.error_code(), status.error_message());
  };

  http.Get("/api/sessions",
           [stub, fail](const httplib::Request& req, httplib::Response& res) {
             v1::ListSessionsResponse all;
             v1::ListSessionsRequest request;
             request.set_page_size(kPageSize);
             request.set_filter(req.get_param_value("filter"));
             for (int page = 0; page < kMaxPages; ++page) {
               v1::ListSessionsResponse response;
               const grpc::Status status =
                   stub->ListSessions(CallContext().get(), request, &response);
               if (!status.ok()) return fail(res, status);
               for (v1::Session& s : *response.mutable_sessions())
                 *all.add_sessions() = std::move(s);
               if (response.next_page_token().empty()) break;
               request.set_page_token(response.next_page_token());
               all.set_next_page_token(response.next_page_token());
             }
             SendMessage(res, all);
           });
  // GET /api/sessions/ID[/what]: the call on "sessions/ID".
  // Each request gets its own messages (workers run handlers concurrently).
  const auto get = [&http, stub](const std::string& what, auto call, auto request_type,
                                 auto response_type) {
    http.Get(absl::StrCat(R"(/api/sessions/([a-z0-9-]{1,63}))", what),
             [stub, call](const httplib::Request& req, httplib::Response& res) {
               decltype(request_type) request;
               decltype(response_type) response;
               request.set_name(absl::StrCat("sessions/", req.matches[1].str()));
               const grpc::Status status =
                   ((*stub).*call)(CallContext().get(), request, &response);
               if (!status.ok())
                 return SendError(res, status.error_code(), status.error_message());
               SendMessage(res, response);
             });
  };
  get("", &v1::ExplorationService::Stub::GetSession, v1::GetSessionRequest(),
      v1::Session());
  get("/history", &v1::ExplorationService::Stub::GetSessionHistory,
      v1::GetSessionHistoryRequest(), v1::SessionHistory());
  get("/archive", &v1::ExplorationService::Stub::ExportSession,
      v1::ExportSessionRequest(), v1::SessionArchive());
  // POST /api/sessions/ID/what: the body the call's request in JSON, its session
  // "sessions/ID".
  const auto post = [&http, stub](const std::string& what, auto call, auto request_type,
                                  auto response_type) {
    http.Post(absl::StrCat(R"(/api/sessions/([a-z0-9-]{1,63})/)", what),
              [stub, call](const httplib::Request& req, httplib::Response& res) {
                decltype(request_type) request;
                decltype(response_type) response;
                google::protobuf::util::JsonParseOptions parse;
                if (auto s = google::protobuf::util::JsonStringToMessage(req.body,
                                                                         &request, parse);
                    !s.ok()) {
                  return SendError(
                      res, grpc::StatusCode::INVALID_ARGUMENT,
                      absl::StrCat("the body is not a ", request.GetDescriptor()->name(),
                                   " in JSON: ", s.ToString()));
                }
                request.set_session(absl::StrCat("sessions/", req.matches[1].str()));
                const grpc::Status status =
                    ((*stub).*call)(CallContext().get(), request, &response);
                if (!status.ok())
                  return SendError(res, status.error_code(), status.error_message());
                SendMessage(res, response);
              });
  };
  post("predict", &v1::ExplorationService::Stub::Predict, v1::PredictRequest(),
       v1::PredictResponse());
  post("rollout", &v1::ExplorationService::Stub::Rollout, v1::RolloutRequest(),
       v1::RolloutResponse());
  http.set_error_handler([](const httplib::Request& req, httplib::Response& res) {
    if (res.status == 404 && res.body.empty()) {
      SendError(res, grpc::StatusCode::NOT_FOUND,
                absl::StrCat("no such page: ", req.path));
    }
  });

  view->port_ = port == 0 ? http.bind_to_any_port(host)
                          : (http.bind_to_port(host, port) ? port : -1);
  if (view->port_ <= 0) {
    return absl::UnavailableError(
        absl::StrCat("web view: cannot listen on ", options.listen));
  }
  view->listener_ = std::thread([&http] { http.listen_after_bind(); });
  // Until it runs, stop() would not reach it (and the destructor would wait).
  for (int i = 0; i < 500 && !http.is_running(); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return view;
}

WebView::~WebView() {
  if (http_ != nullptr) http_->stop();
  if (listener_.joinable()) listener_.join();
}

}  // namespace excite::web
