#include "server/store/postgres_connections.h"

#include <libpq-fe.h>

#include <map>
#include <pqxx/pqxx>
#include <utility>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"

namespace excite::store {
namespace {

// A value in libpq's key=value syntax: single quotes, with ' and \ escaped.
std::string QuoteConninfoValue(const std::string& value) {
  std::string quoted = "'";
  for (char c : value) {
    if (c == '\'' || c == '\\') quoted.push_back('\\');
    quoted.push_back(c);
  }
  quoted.push_back('\'');
  return quoted;
}

absl::StatusCode CodeForSqlState(const std::string& state) {
  if (state == "23505") return absl::StatusCode::kAlreadyExists;
  if (state == "53100") return absl::StatusCode::kResourceExhausted;  // disk full
  if (state == "28000" || state == "28P01") return absl::StatusCode::kFailedPrecondition;
  // Serialization failure, deadlock, lock or statement timeout, an idle
  // transaction ended by the server, connection exceptions (08), a server
  // shutting down or starting (57P0x), insufficient resources (53): retryable.
  if (state == "40001" || state == "40P01" || state == "55P03" || state == "57014" ||
      state == "25P03" || absl::StartsWith(state, "08") ||
      absl::StartsWith(state, "57P") || absl::StartsWith(state, "53")) {
    return absl::StatusCode::kUnavailable;
  }
  return absl::StatusCode::kInternal;
}

}  // namespace

absl::StatusOr<PostgresTarget> ParsePostgresTarget(const std::string& url,
                                                   const std::string& password,
                                                   const std::string& application_name) {
  if (url.empty()) {
    return absl::InvalidArgumentError(
        "the PostgreSQL URL is empty (postgresql://user@host:5432/dbname)");
  }
  char* error = nullptr;
  PQconninfoOption* options = PQconninfoParse(url.c_str(), &error);
  if (options == nullptr) {
    std::string message = error != nullptr ? error : "out of memory";
    PQfreemem(error);
    return absl::InvalidArgumentError(
        absl::StrCat("the PostgreSQL URL does not parse: ", message));
  }
  std::map<std::string, std::string> given;
  for (PQconninfoOption* o = options; o->keyword != nullptr; ++o) {
    if (o->val != nullptr && o->val[0] != '\0') given[o->keyword] = o->val;
  }
  PQconninfoFree(options);
  if (given.count("password") > 0) {
    return absl::InvalidArgumentError(
        "the PostgreSQL URL carries a password: give it in a file "
        "(--store_password_file) or the environment (PGPASSWORD), never on a "
        "command line");
  }
  if (!password.empty()) given["password"] = password;
  // Defaults: give up connecting after 5 s, and notice a server that vanished
  // without closing the connection within about 20 s.
  given.emplace("connect_timeout", "5");
  given.emplace("keepalives", "1");
  given.emplace("keepalives_idle", "10");
  given.emplace("keepalives_interval", "3");
  given.emplace("keepalives_count", "3");
  if (!application_name.empty()) given.emplace("application_name", application_name);

  std::vector<std::string> pairs;
  for (const auto& [key, value] : given) {
    pairs.push_back(absl::StrCat(key, "=", QuoteConninfoValue(value)));
  }
  PostgresTarget target;
  target.conninfo = absl::StrJoin(pairs, " ");
  const auto get = [&given](const char* key, const char* fallback) {
    auto it = given.find(key);
    return it != given.end() ? it->second : std::string(fallback);
  };
  const std::string user = get("user", "");
  target.location = absl::StrCat("postgresql://", user.empty() ? "" : user + "@",
                                 get("host", get("hostaddr", "localhost").c_str()), ":",
                                 get("port", "5432"), "/", get("dbname", user.c_str()));
  return target;
}

absl::Status StatusFromException(const std::exception& e, const std::string& location) {
  const std::string what = e.what();
  if (dynamic_cast<const pqxx::in_doubt_error*>(&e) != nullptr) {
    return absl::UnavailableError(absl::StrCat(
        "the connection to ", location,
        " was lost during COMMIT: the write may or may not be stored (", what, ")"));
  }
  if (dynamic_cast<const pqxx::broken_connection*>(&e) != nullptr) {
    if (absl::StrContains(what, "authentication failed") ||
        absl::StrContains(what, "no password supplied")) {
      return absl::FailedPreconditionError(
          absl::StrCat("PostgreSQL at ", location, " refused the credentials: ", what));
    }
    return absl::UnavailableError(
        absl::StrCat("PostgreSQL at ", location, " cannot be reached: ", what));
  }
  if (const auto* sql = dynamic_cast<const pqxx::sql_error*>(&e)) {
    const std::string state = sql->sqlstate();
    return absl::Status(
        CodeForSqlState(state),
        absl::StrCat("PostgreSQL at ", location, " (SQLSTATE ", state, "): ", what));
  }
  return absl::InternalError(
      absl::StrCat("PostgreSQL at ", location, ": unexpected error: ", what));
}

struct PostgresConnections::Connection {
  explicit Connection(const std::string& conninfo) : connection(conninfo) {}
  pqxx::connection connection;
};

PostgresConnections::PostgresConnections(PostgresTarget target, int size,
                                         std::vector<std::string> settings)
    : target_(std::move(target)), settings_(std::move(settings)) {
  free_.resize(static_cast<size_t>(std::max(1, size)));
}

PostgresConnections::~PostgresConnections() = default;

absl::Status PostgresConnections::Run(
    absl::FunctionRef<absl::Status(pqxx::connection_base&)> body) {
  bool lost = false;
  absl::Status status = RunOnce(body, &lost);
  if (lost) status = RunOnce(body, &lost);
  return status;
}

absl::Status PostgresConnections::RunOnce(
    absl::FunctionRef<absl::Status(pqxx::connection_base&)> body, bool* connection_lost) {
  *connection_lost = false;
  Slot slot;
  {
    absl::MutexLock lock(&mu_);
    mu_.Await(absl::Condition(
        +[](std::vector<Slot>* free) { return !free->empty(); }, &free_));
    slot = std::move(free_.back());
    free_.pop_back();
  }
  absl::Status status;
  // Only a connection that was open before this call can have gone stale (a
  // server restart closes them all); a failure to open one is not retried.
  const bool reused = slot != nullptr && slot->connection.is_open();
  try {
    if (!reused) {
      slot = std::make_unique<Connection>(target_.conninfo);
      for (const std::string& sql : settings_) {
        pqxx::nontransaction setup(slot->connection);
        setup.exec(sql);
      }
    }
    status = body(slot->connection);
  } catch (const std::exception& e) {
    status = StatusFromException(e, target_.location);
    if (dynamic_cast<const pqxx::broken_connection*>(&e) != nullptr ||
        dynamic_cast<const pqxx::in_doubt_error*>(&e) != nullptr) {
      *connection_lost =
          reused && dynamic_cast<const pqxx::broken_connection*>(&e) != nullptr;
      slot.reset();
    } else if (status.code() == absl::StatusCode::kUnavailable) {
      // e.g. the server is shutting down (57P01): the connection is not reused.
      slot.reset();
    }
  }
  absl::MutexLock lock(&mu_);
  free_.push_back(std::move(slot));
  return status;
}

}  // namespace excite::store
