// The excite-server executable as other processes see it: the one stdout line
// announcing the port, grpc.health.v1 SERVING, and a clean exit 0 on SIGTERM.

#include <signal.h>
#include <sys/stat.h>

#include <chrono>
#include <cstdio>
#include <future>
#include <iostream>
#include <string>
#include <thread>

#include "client/excite_client.h"
#include "grpcpp/create_channel.h"
#include "grpcpp/generic/generic_stub.h"
#include "grpcpp/security/credentials.h"
#include "grpcpp/support/byte_buffer.h"
#include "gtest/gtest.h"
#include "server/service/config_text.h"
#include "tests/service/server_process.h"
#include "tests/support/temp_dir.h"

namespace excite::service {
namespace {

using ::excite::testing::ListeningPort;
using ::excite::testing::ServerProcess;

// grpc.health.v1.Health/Check for the whole server (service ""), via a generic
// stub: an empty request; the reply 08 01 means SERVING.
std::string HealthCheck(const std::string& address) {
  grpc::GenericStub stub(
      grpc::CreateChannel(address, grpc::InsecureChannelCredentials()));
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(5));
  grpc::Slice empty("");
  grpc::ByteBuffer request(&empty, 1);  // an empty HealthCheckRequest
  grpc::ByteBuffer response;
  std::promise<grpc::Status> done;
  stub.UnaryCall(&context, "/grpc.health.v1.Health/Check", grpc::StubOptions(), &request,
                 &response, [&done](grpc::Status s) { done.set_value(s); });
  grpc::Status status = done.get_future().get();
  if (!status.ok()) return "error: " + status.error_message();
  grpc::Slice slice;
  if (!response.TrySingleSlice(&slice).ok() && !response.DumpToSingleSlice(&slice).ok()) {
    return "unreadable";
  }
  return std::string(reinterpret_cast<const char*>(slice.begin()), slice.size());
}

TEST(ServerBinaryTest, AnnouncesPortServesHealthAndExitsCleanlyOnSigterm) {
  excite::testing::TempDir tmp;
  ServerProcess server(tmp.path() + "/data");
  ASSERT_GT(server.pid(), 0);
  const std::string line = server.ReadLine();
  const std::string port = ListeningPort(line);
  ASSERT_FALSE(port.empty()) << "stdout line: \"" << line << "\"";
  const std::string address = "127.0.0.1:" + port;
  EXPECT_NE(port, "0");

  EXPECT_EQ(HealthCheck(address), std::string("\x08\x01", 2));  // SERVING

  auto client = client::ExciteClient::Connect(address);
  absl::StatusOr<v1::SessionConfig> config = ParseSessionConfigText(R"pb(
    state_dim: 1
    input_dim: 1
    input_bounds { lower: -1 upper: 1 }
    noise { variance: 0.01 }
    kernel { fit: true }
  )pb");
  ASSERT_TRUE(config.ok());
  ASSERT_TRUE(client->CreateSession(*config, "bin").ok());

  const auto t0 = std::chrono::steady_clock::now();
  // With the client's connection still open, the drain must not wait for the
  // whole grace period (5 s) when nothing is in flight.
  EXPECT_EQ(server.SignalAndWait(SIGTERM, std::chrono::seconds(15)), 0);
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(3));
  std::cout
      << "SIGTERM to exit: "
      << std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count()
      << " s\n";
  EXPECT_EQ(server.ReadRest(), "");  // exactly one line on stdout

  // The session is durable: a new server on the same directory has it.
  ServerProcess again(tmp.path() + "/data");
  const std::string port2 = ListeningPort(again.ReadLine());
  ASSERT_FALSE(port2.empty());
  auto client2 = client::ExciteClient::Connect("127.0.0.1:" + port2);
  EXPECT_TRUE(client2->GetSession("sessions/bin").ok());
  EXPECT_EQ(again.SignalAndWait(SIGINT, std::chrono::seconds(15)), 0);
}

TEST(ServerBinaryTest, RefusesAnEmptyAuthTokenFromTheEnvironment) {
  excite::testing::TempDir tmp;
  // The child inherits the environment; an empty token used to switch
  // authentication off silently.
  ASSERT_EQ(setenv("EXCITE_AUTH_TOKEN", " ", 1), 0);
  ServerProcess server(tmp.path() + "/data");
  unsetenv("EXCITE_AUTH_TOKEN");
  EXPECT_EQ(server.ReadLine(), "");  // never listened
  EXPECT_EQ(server.SignalAndWait(0, std::chrono::seconds(15)), 2);
}

TEST(ServerBinaryTest, StoreFilesArePrivateWhateverTheUmask) {
  excite::testing::TempDir tmp;
  const std::string dir = tmp.path() + "/data";
  const mode_t old_umask = umask(0);  // inherited by the child
  ServerProcess server(dir);
  umask(old_umask);
  ASSERT_FALSE(ListeningPort(server.ReadLine()).empty());
  // The store is open (and its schema written) once the server listens.
  struct stat st {};
  ASSERT_EQ(stat(dir.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0700u);
  for (const char* name :
       {"excite.db", "excite.db-wal", "excite.db-shm", "excite.lock"}) {
    const std::string path = dir + "/" + name;
    ASSERT_EQ(stat(path.c_str(), &st), 0) << path;
    EXPECT_EQ(st.st_mode & 0777, 0600u) << path;
  }
  EXPECT_EQ(server.SignalAndWait(SIGTERM, std::chrono::seconds(15)), 0);
}

}  // namespace
}  // namespace excite::service
