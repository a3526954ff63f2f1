#ifndef EXCITE_TESTS_E2E_SUBPROCESS_H_
#define EXCITE_TESTS_E2E_SUBPROCESS_H_

#include <sys/types.h>

#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"

namespace excite::testing {

// A child process for end-to-end tests (fork + execv). Its stdout and stderr go to
// files, so it can never block on a full pipe. It cannot outlive the test: it gets
// SIGKILL if the test process dies (PR_SET_PDEATHSIG), and the destructor kills and
// reaps it if it still runs. Not thread-safe.
class Subprocess {
 public:
  // argv[0] is the executable's path. stdout_path / stderr_path are created or
  // truncated.
  static absl::StatusOr<std::unique_ptr<Subprocess>> Start(
      const std::vector<std::string>& argv, const std::string& stdout_path,
      const std::string& stderr_path);
  ~Subprocess();
  Subprocess(const Subprocess&) = delete;
  Subprocess& operator=(const Subprocess&) = delete;

  pid_t pid() const { return pid_; }
  // Sends `signal` (no-op once the child has been reaped).
  void Signal(int signal);
  // Waits up to `timeout` for the child to exit. Returns its exit code, or 128 +
  // signal number if a signal ended it; DEADLINE_EXCEEDED if it still runs.
  absl::StatusOr<int> Wait(std::chrono::milliseconds timeout);
  // Polls the stdout file until a line starting with `prefix` is complete, and
  // returns that line (without newline). DEADLINE_EXCEEDED on timeout, ABORTED (with
  // the exit code) if the child exits first.
  absl::StatusOr<std::string> WaitForStdoutLine(const std::string& prefix,
                                                std::chrono::milliseconds timeout);
  const std::string& stdout_path() const { return stdout_path_; }
  const std::string& stderr_path() const { return stderr_path_; }

 private:
  Subprocess(pid_t pid, std::string stdout_path, std::string stderr_path)
      : pid_(pid),
        stdout_path_(std::move(stdout_path)),
        stderr_path_(std::move(stderr_path)) {}
  // waitpid(WNOHANG); true once the child has been reaped.
  bool Poll();

  pid_t pid_;
  bool reaped_ = false;
  int exit_code_ = -1;
  std::string stdout_path_;
  std::string stderr_path_;
};

// The whole content of a file ("" if it cannot be read).
std::string ReadFileOrEmpty(const std::string& path);

}  // namespace excite::testing

#endif  // EXCITE_TESTS_E2E_SUBPROCESS_H_
