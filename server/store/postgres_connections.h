#ifndef EXCITE_SERVER_STORE_POSTGRES_CONNECTIONS_H_
#define EXCITE_SERVER_STORE_POSTGRES_CONNECTIONS_H_

#include <exception>
#include <memory>
#include <string>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/functional/function_ref.h"
#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"

namespace pqxx {
class connection_base;
}

namespace excite::store {

// Where a PostgresStore connects: the user's URL or key=value string, checked.
struct PostgresTarget {
  // What libpq gets: the user's parameters, the password, and excite's defaults
  // where the user set none (connect_timeout 5 s, TCP keepalives, an
  // application_name).
  std::string conninfo;
  // postgresql://user@host:port/dbname, for log lines: never a password.
  std::string location;
};

// INVALID_ARGUMENT if `url` does not parse (libpq's PQconninfoParse) or carries a
// password: passwords come from `password` (a file or the environment), never
// from a command line. `application_name` is set unless the URL has one.
absl::StatusOr<PostgresTarget> ParsePostgresTarget(const std::string& url,
                                                   const std::string& password,
                                                   const std::string& application_name);

// A libpqxx exception as a status (see PostgresStore's errors): UNAVAILABLE for
// what a retry can cure, ALREADY_EXISTS for a unique violation,
// FAILED_PRECONDITION for refused credentials, RESOURCE_EXHAUSTED for a full
// disk, INTERNAL otherwise. `location` names the server in the message.
absl::Status StatusFromException(const std::exception& e, const std::string& location);

// A fixed number of connections to one server, each used by one call at a
// time, opened on first use and reopened after they broke. Thread-safe.
class PostgresConnections {
 public:
  // `settings` are SQL statements run on every new connection (SET ...).
  PostgresConnections(PostgresTarget target, int size, std::vector<std::string> settings);
  ~PostgresConnections();
  PostgresConnections(const PostgresConnections&) = delete;
  PostgresConnections& operator=(const PostgresConnections&) = delete;

  const std::string& location() const { return target_.location; }

  // Runs `body` (one transaction) on a free connection (waiting for one),
  // opening it if needed. Exceptions become statuses (StatusFromException); a
  // connection that broke is dropped. A body that failed because a connection
  // opened earlier was found broken (e.g. the server restarted since) runs once
  // more on a new connection: its transaction was rolled back (a connection
  // lost during COMMIT is in doubt, UNAVAILABLE, and never run again).
  absl::Status Run(absl::FunctionRef<absl::Status(pqxx::connection_base&)> body);

 private:
  // A connection slot: nullptr until opened (or after it broke). (A wrapper:
  // libpqxx 6's connection_base has no virtual destructor.)
  struct Connection;
  using Slot = std::unique_ptr<Connection>;
  absl::Status RunOnce(absl::FunctionRef<absl::Status(pqxx::connection_base&)> body,
                       bool* connection_lost);

  const PostgresTarget target_;
  const std::vector<std::string> settings_;
  absl::Mutex mu_;
  std::vector<Slot> free_ ABSL_GUARDED_BY(mu_);
};

}  // namespace excite::store

#endif  // EXCITE_SERVER_STORE_POSTGRES_CONNECTIONS_H_
