#include "tests/support/postgres_server.h"

#include <fcntl.h>
#include <glob.h>
#include <pwd.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <pqxx/pqxx>
#include <random>
#include <sstream>
#include <system_error>

#include "absl/strings/str_cat.h"
#include "tests/support/child_process.h"

namespace excite::testing {
namespace {

// The newest installed PostgreSQL's bin directory, or "".
std::string FindBinDir() {
  glob_t found{};
  std::string best;
  if (glob("/usr/lib/postgresql/*/bin/initdb", 0, nullptr, &found) == 0) {
    for (size_t i = 0; i < found.gl_pathc; ++i) {
      const std::string path = found.gl_pathv[i];
      if (path > best) best = path;  // "15" > "14"; fine for the versions Debian has
    }
  }
  globfree(&found);
  return best.empty() ? "" : std::filesystem::path(best).parent_path().string();
}

std::string Tail(const std::string& path) {
  std::ifstream in(path);
  std::stringstream all;
  all << in.rdbuf();
  const std::string text = all.str();
  return text.size() > 2000 ? text.substr(text.size() - 2000) : text;
}

}  // namespace

absl::StatusOr<std::unique_ptr<PostgresServer>> PostgresServer::Start() {
  std::unique_ptr<PostgresServer> server(new PostgresServer());
  server->bin_ = FindBinDir();
  if (server->bin_.empty()) {
    return absl::FailedPreconditionError(
        "no PostgreSQL server binaries in /usr/lib/postgresql/*/bin (scripts/setup.sh "
        "installs postgresql-15)");
  }
  const char* base = std::getenv("TMPDIR");
  std::string pattern =
      std::string(base != nullptr && *base != '\0' ? base : "/tmp") + "/excite-pg-XXXXXX";
  if (mkdtemp(pattern.data()) == nullptr) {
    return absl::InternalError("cannot create a temporary directory");
  }
  server->dir_ = pattern;
  server->data_ = server->dir_ + "/data";
  server->log_ = server->dir_ + "/postgres.log";
  server->password_file_ = server->dir_ + "/password";
  std::random_device random;
  server->password_ = absl::StrCat("pw-", random(), "-", random());
  {
    std::ofstream(server->password_file_) << server->password_ << "\n";
    std::ofstream(server->log_) << "";
  }
  if (::geteuid() == 0) {
    // initdb refuses root: the cluster and its files belong to "nobody".
    const passwd* nobody = ::getpwnam("nobody");
    if (nobody == nullptr) return absl::FailedPreconditionError("no user nobody");
    for (const std::string& path : {server->dir_, server->password_file_, server->log_}) {
      if (::chown(path.c_str(), nobody->pw_uid, nobody->pw_gid) != 0) {
        return absl::InternalError(absl::StrCat("cannot chown ", path));
      }
    }
    server->as_user_ = absl::StrCat("setpriv --reuid=", nobody->pw_uid,
                                    " --regid=", nobody->pw_gid, " --clear-groups -- ");
  }
  if (absl::Status s = server->StartWatchdog(); !s.ok()) return s;
  if (absl::Status s = server->Run(
          absl::StrCat(
              server->bin_, "/initdb -D ", server->data_,
              " -U excite --auth=scram-sha-256 --pwfile=", server->password_file_,
              " --no-sync --no-instructions -E UTF8 --locale=C"),
          "initdb");
      !s.ok()) {
    return s;
  }
  server->port_ = FreeLoopbackPort();
  if (absl::Status s = server->StartAgain(); !s.ok()) return s;
  return server;
}

absl::Status PostgresServer::StartWatchdog() {
  // Prepared before fork(): the child (of a process with threads) only reads,
  // then execs.
  const std::string command =
      absl::StrCat(as_user_, bin_, "/pg_ctl -D ", data_, " -m immediate -w stop >> ",
                   log_, " 2>&1; rm -rf ", dir_);
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) return absl::InternalError("pipe2 failed");
  const pid_t pid = ::fork();
  if (pid < 0) return absl::InternalError("fork failed");
  if (pid == 0) {
    ::close(fds[1]);
    char byte;
    while (::read(fds[0], &byte, 1) > 0) {
    }
    ::execl("/bin/sh", "sh", "-c", command.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  ::close(fds[0]);
  watchdog_pipe_ = fds[1];
  watchdog_ = pid;
  return absl::OkStatus();
}

PostgresServer::~PostgresServer() {
  if (watchdog_ > 0) {
    ::close(watchdog_pipe_);  // the watchdog stops the server and removes dir_
    ::waitpid(watchdog_, nullptr, 0);
    return;
  }
  std::error_code ec;
  if (!dir_.empty()) std::filesystem::remove_all(dir_, ec);
}

absl::Status PostgresServer::Run(const std::string& command, const std::string& what) {
  const std::string full = absl::StrCat(as_user_, command, " >> ", log_, " 2>&1");
  const int rc = std::system(full.c_str());
  if (rc == 0) return absl::OkStatus();
  return absl::InternalError(
      absl::StrCat(what, " failed (", rc, "): ", full, "\n", Tail(log_)));
}

absl::Status PostgresServer::StartAgain() {
  absl::Status s =
      Run(absl::StrCat(bin_, "/pg_ctl -D ", data_, " -l ", log_, " -w -t 60 -o \"-p ",
                       port_, " -k ", dir_, " -c listen_addresses=127.0.0.1\" start"),
          "pg_ctl start");
  return s;
}

absl::Status PostgresServer::Stop() {
  return Run(absl::StrCat(bin_, "/pg_ctl -D ", data_, " -m fast -w stop"), "pg_ctl stop");
}

std::string PostgresServer::url(const std::string& dbname) const {
  return absl::StrCat("postgresql://excite@127.0.0.1:", port_, "/", dbname);
}

std::string PostgresServer::Conninfo(const std::string& dbname) const {
  return absl::StrCat("host=127.0.0.1 port=", port_, " user=excite dbname=", dbname,
                      " password=", password_);
}

absl::StatusOr<std::string> PostgresServer::Query(const std::string& sql,
                                                  const std::string& dbname) {
  try {
    pqxx::connection conn(Conninfo(dbname));
    pqxx::nontransaction tx(conn);
    const pqxx::result rows = tx.exec(sql);
    if (rows.empty() || rows[0].empty() || rows[0][0].is_null()) return std::string();
    return rows[0][0].as<std::string>();
  } catch (const std::exception& e) {
    return absl::InternalError(absl::StrCat("query \"", sql, "\": ", e.what()));
  }
}

absl::Status PostgresServer::CreateDatabase(const std::string& name) {
  return Query(absl::StrCat("CREATE DATABASE \"", name, "\""), "postgres").status();
}

}  // namespace excite::testing
