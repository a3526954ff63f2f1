#ifndef EXCITE_TESTS_SERVICE_SERVER_PROCESS_H_
#define EXCITE_TESTS_SERVICE_SERVER_PROCESS_H_

// The excite-server executable run as a child process (tests only).

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <string>
#include <thread>

#ifndef EXCITE_SERVER_BINARY
#error "EXCITE_SERVER_BINARY must name the excite-server executable"
#endif

namespace excite::testing {

// A child excite-server whose stdout is read through a pipe.
class ServerProcess {
 public:
  // `extra_flag` (if not empty) is passed as one more argument.
  explicit ServerProcess(const std::string& data_dir,
                         const std::string& extra_flag = "") {
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
      if (extra_flag.empty()) {
        execl(EXCITE_SERVER_BINARY, EXCITE_SERVER_BINARY, "--listen=127.0.0.1:0",
              data_flag.c_str(), "--log_level=warning", static_cast<char*>(nullptr));
      } else {
        execl(EXCITE_SERVER_BINARY, EXCITE_SERVER_BINARY, "--listen=127.0.0.1:0",
              data_flag.c_str(), "--log_level=warning", extra_flag.c_str(),
              static_cast<char*>(nullptr));
      }
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

// The port of "excite-server listening on 127.0.0.1:PORT", or "" if the line
// is not exactly that. (No std::regex: GCC 12 warns inside it under ASan.)
inline std::string ListeningPort(const std::string& line) {
  const std::string prefix = "excite-server listening on 127.0.0.1:";
  if (line.compare(0, prefix.size(), prefix) != 0) return "";
  const std::string port = line.substr(prefix.size());
  if (port.empty() || port.size() > 5) return "";
  for (char c : port) {
    if (c < '0' || c > '9') return "";
  }
  return port;
}

}  // namespace excite::testing

#endif  // EXCITE_TESTS_SERVICE_SERVER_PROCESS_H_
