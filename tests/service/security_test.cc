// excite-server's transport security over real loopback: bearer tokens (plaintext
// on loopback and over TLS), TLS with a certificate made by openssl at test time,
// and mutual TLS. Health checks stay open without a token or a client certificate.

#include <cstdlib>
#include <fstream>
#include <future>
#include <memory>
#include <sstream>
#include <string>

#include "absl/strings/str_cat.h"
#include "client/excite_client.h"
#include "grpcpp/create_channel.h"
#include "grpcpp/generic/generic_stub.h"
#include "grpcpp/security/credentials.h"
#include "grpcpp/support/byte_buffer.h"
#include "gtest/gtest.h"
#include "server/service/excite_server.h"
#include "tests/support/temp_dir.h"

namespace excite::service {
namespace {

using client::ClientOptions;
using client::ExciteClient;

// grpc.health.v1.Health/Check (service ""), plaintext unless `credentials`
// are given; "" on error.
std::string HealthCheck(const std::string& address,
                        std::shared_ptr<grpc::ChannelCredentials> credentials =
                            grpc::InsecureChannelCredentials()) {
  grpc::GenericStub stub(grpc::CreateChannel(address, credentials));
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(5));
  grpc::Slice empty("");
  grpc::ByteBuffer request(&empty, 1);
  grpc::ByteBuffer response;
  std::promise<grpc::Status> done;
  stub.UnaryCall(&context, "/grpc.health.v1.Health/Check", grpc::StubOptions(), &request,
                 &response, [&done](grpc::Status s) { done.set_value(s); });
  if (!done.get_future().get().ok()) return "";
  grpc::Slice slice;
  if (!response.DumpToSingleSlice(&slice).ok()) return "";
  return std::string(reinterpret_cast<const char*>(slice.begin()), slice.size());
}

absl::StatusCode ListCode(const std::string& address, ClientOptions options) {
  options.default_deadline = std::chrono::seconds(5);
  return ExciteClient::Connect(address, options)->ListSessions(0, "").status().code();
}

class SecurityTest : public ::testing::Test {
 protected:
  std::unique_ptr<ExciteServer> StartServer(const SecurityOptions& security) {
    ServerOptions options;
    options.listen = "127.0.0.1:0";
    options.data_dir = tmp_.path() + "/data";
    options.security = security;
    absl::StatusOr<std::unique_ptr<ExciteServer>> server = ExciteServer::Start(options);
    EXPECT_TRUE(server.ok()) << server.status();
    return server.ok() ? *std::move(server) : nullptr;
  }

  // A CA, a server certificate for 127.0.0.1 and a client certificate, all
  // signed by the CA, and a self-signed "foreign" client certificate, in the temp
  // dir (never committed).
  void MakeCertificates() {
    const std::string d = tmp_.path();
    const std::string script = absl::StrCat(
        "set -e; cd '", d,
        "'; exec >openssl.log 2>&1;"
        "openssl req -x509 -newkey rsa:2048 -nodes -keyout ca.key -out ca.pem "
        "-days 1 -subj /CN=excite-test-ca;"
        "printf 'subjectAltName=IP:127.0.0.1,DNS:localhost\\n' > server.ext;"
        "openssl req -newkey rsa:2048 -nodes -keyout server.key -out server.csr "
        "-subj /CN=localhost;"
        "openssl x509 -req -in server.csr -CA ca.pem -CAkey ca.key -CAcreateserial "
        "-out server.pem -days 1 -extfile server.ext;"
        "openssl req -newkey rsa:2048 -nodes -keyout client.key -out client.csr "
        "-subj /CN=excite-test-client;"
        "openssl x509 -req -in client.csr -CA ca.pem -CAkey ca.key -CAcreateserial "
        "-out client.pem -days 1;"
        "openssl req -x509 -newkey rsa:2048 -nodes -keyout foreign.key -out foreign.pem "
        "-days 1 -subj /CN=excite-test-foreign");
    ASSERT_EQ(std::system(script.c_str()), 0) << "openssl failed, see " << d;
  }
  std::string File(const std::string& name) const { return tmp_.path() + "/" + name; }

  excite::testing::TempDir tmp_;
};

TEST_F(SecurityTest, BearerTokenOnPlaintextLoopback) {
  SecurityOptions security;
  security.auth_token = "s3cret-token";
  std::unique_ptr<ExciteServer> server = StartServer(security);
  ASSERT_NE(server, nullptr);
  const std::string address = server->address();

  EXPECT_EQ(ListCode(address, {}), absl::StatusCode::kUnauthenticated);
  ClientOptions wrong;
  wrong.auth_token = "s3cret-tokeN";
  EXPECT_EQ(ListCode(address, wrong), absl::StatusCode::kUnauthenticated);
  ClientOptions right;
  right.auth_token = "s3cret-token";
  EXPECT_EQ(ListCode(address, right), absl::StatusCode::kOk);
  // Probes need no token.
  EXPECT_EQ(HealthCheck(address), std::string("\x08\x01", 2));
}

TEST_F(SecurityTest, TokenWithoutTlsIsRefusedOffLoopback) {
  ServerOptions options;
  options.listen = "0.0.0.0:0";
  options.data_dir = tmp_.path() + "/data";
  options.security.auth_token = "t";
  absl::StatusOr<std::unique_ptr<ExciteServer>> server = ExciteServer::Start(options);
  EXPECT_EQ(server.status().code(), absl::StatusCode::kInvalidArgument);
}

TEST_F(SecurityTest, TlsWorksAndPlaintextClientFails) {
  ASSERT_NO_FATAL_FAILURE(MakeCertificates());
  SecurityOptions security;
  security.tls_cert_file = File("server.pem");
  security.tls_key_file = File("server.key");
  security.auth_token = "tok";
  std::unique_ptr<ExciteServer> server = StartServer(security);
  ASSERT_NE(server, nullptr);
  const std::string address = server->address();

  ClientOptions tls;
  tls.tls_ca_file = File("ca.pem");
  tls.auth_token = "tok";
  EXPECT_EQ(ListCode(address, tls), absl::StatusCode::kOk);
  tls.auth_token = "";
  EXPECT_EQ(ListCode(address, tls), absl::StatusCode::kUnauthenticated);
  ClientOptions plaintext;
  plaintext.auth_token = "tok";
  EXPECT_EQ(ListCode(address, plaintext), absl::StatusCode::kUnavailable);
}

TEST_F(SecurityTest, MutualTlsNeedsAClientCertificateForAllButHealthChecks) {
  ASSERT_NO_FATAL_FAILURE(MakeCertificates());
  SecurityOptions security;
  security.tls_cert_file = File("server.pem");
  security.tls_key_file = File("server.key");
  security.tls_client_ca_file = File("ca.pem");
  std::unique_ptr<ExciteServer> server = StartServer(security);
  ASSERT_NE(server, nullptr);
  const std::string address = server->address();

  ClientOptions no_cert;
  no_cert.tls_ca_file = File("ca.pem");
  EXPECT_EQ(ListCode(address, no_cert), absl::StatusCode::kUnauthenticated);
  ClientOptions with_cert = no_cert;
  with_cert.tls_cert_file = File("client.pem");
  with_cert.tls_key_file = File("client.key");
  EXPECT_EQ(ListCode(address, with_cert), absl::StatusCode::kOk);
  // A certificate the client CA did not sign fails the handshake.
  ClientOptions foreign_cert = no_cert;
  foreign_cert.tls_cert_file = File("foreign.pem");
  foreign_cert.tls_key_file = File("foreign.key");
  EXPECT_EQ(ListCode(address, foreign_cert), absl::StatusCode::kUnavailable);

  // Probes need no secret: a TLS health check without a client certificate.
  std::ifstream ca_file(File("ca.pem"));
  std::stringstream ca;
  ca << ca_file.rdbuf();
  grpc::SslCredentialsOptions ssl;
  ssl.pem_root_certs = ca.str();
  EXPECT_EQ(HealthCheck(address, grpc::SslCredentials(ssl)), std::string("\x08\x01", 2));
}

}  // namespace
}  // namespace excite::service
