// The excite-server executable as other processes see it: the one stdout line
// announcing the port, grpc.health.v1 SERVING, and a clean exit 0 on SIGTERM.

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

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
#include "tests/service/temp_dir.h"

#ifndef EXCITE_SERVER_BINARY
#error "EXCITE_SERVER_BINARY must name the excite-server executable"
#endif

namespace excite::service {
namespace {

// A child excite-server whose stdout is read through a pipe.
class ServerProcess {
 public:
  explicit ServerProcess(const std::string& data_dir) {
    // Everything the child needs is prepared before fork(): between fork and
    // exec only async-signal-safe calls (the test process has threads).
    const std::string data_flag = "--data_dir=" + data_dir;
    int fds[2];
    if (pipe2(fds, O_CLOEXEC) != 0) return;  // dup2 below clears CLOEXEC on stdout
    pid_ = fork();
    if (pid_ == 0) {
      prctl(PR_SET_PDEATHSIG, SIGKILL);  // never outlive a crashed test
      dup2(fds[1], STDOUT_FILENO);
      close(fds[0]);
      close(fds[1]);
      execl(EXCITE_SERVER_BINARY, EXCITE_SERVER_BINARY, "--listen=127.0.0.1:0",
            data_flag.c_str(), "--log_level=warning", static_cast<char*>(nullptr));
      _exit(127);
    }
    close(fds[1]);
    out_ = fdopen(fds[0], "r");
  }
  ~ServerProcess() {
    if (pid_ > 0 && !reaped_) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
    if (out_ != nullptr) fclose(out_);
  }

  // One line of stdout without its newline; empty at EOF.
  std::string ReadLine() {
    std::string line;
    int c;
    while (out_ != nullptr && (c = fgetc(out_)) != EOF && c != '\n')
      line.push_back(static_cast<char>(c));
    return line;
  }
  std::string ReadRest() {
    std::string rest;
    int c;
    while (out_ != nullptr && (c = fgetc(out_)) != EOF)
      rest.push_back(static_cast<char>(c));
    return rest;
  }

  // Exit status after `signal`, or -1 if it did not exit within `timeout`.
  int SignalAndWait(int signal, std::chrono::seconds timeout) {
    kill(pid_, signal);
    const auto end = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < end) {
      int status = 0;
      if (waitpid(pid_, &status, WNOHANG) == pid_) {
        reaped_ = true;
        return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return -1;
  }

  pid_t pid() const { return pid_; }

 private:
  pid_t pid_ = -1;
  bool reaped_ = false;
  FILE* out_ = nullptr;
};

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

// The port of "excite-server listening on 127.0.0.1:PORT", or "" if the line
// is not exactly that. (No std::regex: GCC 12 warns inside it under ASan.)
std::string ListeningPort(const std::string& line) {
  const std::string prefix = "excite-server listening on 127.0.0.1:";
  if (line.compare(0, prefix.size(), prefix) != 0) return "";
  const std::string port = line.substr(prefix.size());
  if (port.empty() || port.size() > 5) return "";
  for (char c : port) {
    if (c < '0' || c > '9') return "";
  }
  return port;
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

}  // namespace
}  // namespace excite::service
