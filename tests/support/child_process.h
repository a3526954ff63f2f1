#ifndef EXCITE_TESTS_SUPPORT_CHILD_PROCESS_H_
#define EXCITE_TESTS_SUPPORT_CHILD_PROCESS_H_

#include <sys/types.h>

#include <chrono>
#include <string>
#include <vector>

namespace excite::testing {

// A program run as a child process for tests and benchmarks: stdout and
// stderr appended to a log file, killed (SIGKILL) with its parent and on
// destruction unless it was waited for.
class ChildProcess {
 public:
  // Starts argv[0] with `argv` (a path, not looked up in PATH). pid() is -1 if
  // fork failed.
  ChildProcess(std::vector<std::string> argv, const std::string& log_path);
  ~ChildProcess();
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  pid_t pid() const { return pid_; }
  bool running();
  // Sends `signal` (SIGKILL, SIGSTOP, SIGCONT, SIGTERM, ...).
  void Signal(int signal);
  // Exit status (128 + signal if killed), or -1 if it did not end in `timeout`.
  int Wait(std::chrono::milliseconds timeout);
  // The log so far.
  std::string Log() const;

 private:
  pid_t pid_ = -1;
  bool reaped_ = false;
  int status_ = -1;
  std::string log_path_;
};

// A TCP port on 127.0.0.1 that was free a moment ago (bind to port 0, close).
int FreeLoopbackPort();

}  // namespace excite::testing

#endif  // EXCITE_TESTS_SUPPORT_CHILD_PROCESS_H_
