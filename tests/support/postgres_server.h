#ifndef EXCITE_TESTS_SUPPORT_POSTGRES_SERVER_H_
#define EXCITE_TESTS_SUPPORT_POSTGRES_SERVER_H_

#include <sys/types.h>

#include <memory>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace excite::testing {

// A real PostgreSQL server for tests, from Debian's binaries
// (/usr/lib/postgresql/*/bin): a fresh cluster in a temporary directory
// (initdb, then pg_ctl), listening on 127.0.0.1 at a free port, with password
// (SCRAM) authentication for the superuser "excite". initdb refuses to run as
// root, so as root the cluster belongs to the unprivileged user "nobody".
// Stopped (immediate) and removed on destruction, and also when the test process
// dies without destructing it (a crash, an abort under a sanitizer): a watchdog
// child waits for the test process's end.
class PostgresServer {
 public:
  // FAILED_PRECONDITION if the binaries are missing (scripts/setup.sh installs
  // postgresql-15), INTERNAL if initdb or the start fails (the log is in the
  // message).
  static absl::StatusOr<std::unique_ptr<PostgresServer>> Start();
  ~PostgresServer();
  PostgresServer(const PostgresServer&) = delete;
  PostgresServer& operator=(const PostgresServer&) = delete;

  // postgresql://excite@127.0.0.1:PORT/DBNAME: no password (see password()).
  std::string url(const std::string& dbname = "excite") const;
  const std::string& password() const { return password_; }
  int port() const { return port_; }
  // A file holding the password, readable by this process.
  const std::string& password_file() const { return password_file_; }

  // CREATE DATABASE `name` (a fresh, empty one).
  absl::Status CreateDatabase(const std::string& name);
  // Runs `sql` in database `dbname` and returns the first column of the first
  // row as text ("" if there is none).
  absl::StatusOr<std::string> Query(const std::string& sql,
                                    const std::string& dbname = "excite");

  // pg_ctl stop -m fast / start again on the same port and data.
  absl::Status Stop();
  absl::Status StartAgain();

 private:
  PostgresServer() = default;
  // Runs `command` (as the cluster's user), output appended to the log; the
  // log's tail in the error.
  absl::Status Run(const std::string& command, const std::string& what);
  // Forks the watchdog (before initdb: it also removes a half-made cluster).
  absl::Status StartWatchdog();
  std::string Conninfo(const std::string& dbname) const;

  std::string bin_;
  std::string dir_;
  std::string data_;
  std::string log_;
  std::string password_;
  std::string password_file_;
  std::string as_user_;  // "setpriv ... --" when root, else ""
  int port_ = 0;
  // The watchdog: it stops the server and removes dir_ once this end closes.
  int watchdog_pipe_ = -1;
  pid_t watchdog_ = -1;
};

}  // namespace excite::testing

#endif  // EXCITE_TESTS_SUPPORT_POSTGRES_SERVER_H_
