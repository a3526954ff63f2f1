#include "server/store/sqlite_store.h"

#include <fcntl.h>
#include <sqlite3.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <system_error>
#include <utility>

#include "absl/strings/str_cat.h"
#include "server/store/sample_rows.h"
#include "server/store/sqlite_statement.h"

namespace excite::store {
namespace {

constexpr char kCreateTables[] = R"sql(
CREATE TABLE schema_version (version INTEGER NOT NULL);
CREATE TABLE sessions (
  id TEXT PRIMARY KEY NOT NULL,
  config BLOB NOT NULL,
  created_unix_ms INTEGER NOT NULL,
  hyperparameters BLOB NOT NULL DEFAULT x'',
  model_version INTEGER NOT NULL DEFAULT 0,
  display_name TEXT NOT NULL DEFAULT ''
);
CREATE TABLE samples (
  session_id TEXT NOT NULL,
  sequence INTEGER NOT NULL,
  state BLOB NOT NULL,
  input BLOB NOT NULL,
  next_state BLOB NOT NULL,
  timestamp_s REAL NOT NULL,
  PRIMARY KEY (session_id, sequence)
) WITHOUT ROWID;
)sql";

// Created with the tables above, and by the migration from version 1.
constexpr char kCreateSessionLabels[] = R"sql(
CREATE TABLE session_labels (
  session_id TEXT NOT NULL,
  key TEXT NOT NULL,
  value TEXT NOT NULL,
  PRIMARY KEY (session_id, key)
) WITHOUT ROWID;
)sql";

// Version 1 had neither display names nor labels; its rows get empty ones.
constexpr char kMigrateFromVersion1[] = R"sql(
ALTER TABLE sessions ADD COLUMN display_name TEXT NOT NULL DEFAULT '';
UPDATE schema_version SET version = 2;
)sql";

// The columns of a SessionRecord but its labels, in SessionFromRow's order.
constexpr char kSelectSessions[] =
    "SELECT id, config, created_unix_ms, hyperparameters, model_version, display_name "
    "FROM sessions";

SessionRecord SessionFromRow(const SqliteStatement& stmt) {
  SessionRecord record;
  record.id = stmt.ColumnText(0);
  record.config = stmt.ColumnBlob(1);
  record.created_unix_ms = stmt.ColumnInt64(2);
  record.hyperparameters = stmt.ColumnBlob(3);
  record.model_version = stmt.ColumnInt64(4);
  record.display_name = stmt.ColumnText(5);
  return record;
}

// Holds an exclusive flock on <data_dir>/excite.lock for the store's lifetime so
// that two servers never share one data directory.
absl::StatusOr<int> LockDataDir(const std::filesystem::path& dir) {
  const std::string lock_path = (dir / "excite.lock").string();
  const int fd = ::open(lock_path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0600);
  if (fd < 0) {
    return absl::FailedPreconditionError(
        absl::StrCat("cannot open ", lock_path, ": ", std::strerror(errno)));
  }
  if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
    const int err = errno;
    ::close(fd);
    if (err == EWOULDBLOCK) {
      return absl::FailedPreconditionError(absl::StrCat(
          "data directory ", dir.string(), " is in use by another excite-server (",
          lock_path, " is locked)"));
    }
    return absl::FailedPreconditionError(
        absl::StrCat("cannot lock ", lock_path, ": ", std::strerror(err)));
  }
  return fd;
}

// The store holds users' measurements: only the server's user may read it,
// whatever the umask or the files' earlier modes. SQLite creates -wal and -shm
// with the mode of the database file, so that file is created (or narrowed)
// before SQLite opens it; files left by an older version are narrowed too. The
// directory becomes 0700 when the server's user owns it; a directory owned by
// someone else (a Kubernetes volume with fsGroup) keeps its mode, the files
// inside are 0600 all the same.
absl::Status RestrictPermissions(const std::filesystem::path& dir) {
  std::error_code ec;
  struct stat dir_stat {};
  if (::stat(dir.c_str(), &dir_stat) == 0 && dir_stat.st_uid == ::geteuid()) {
    std::filesystem::permissions(dir, std::filesystem::perms::owner_all,
                                 std::filesystem::perm_options::replace, ec);
    if (ec) {
      return absl::FailedPreconditionError(
          absl::StrCat("cannot make data directory ", dir.string(),
                       " private (0700): ", ec.message()));
    }
  }
  const std::filesystem::path db = dir / "excite.db";
  const int fd = ::open(db.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0600);
  if (fd < 0) {
    return absl::FailedPreconditionError(
        absl::StrCat("cannot open ", db.string(), ": ", std::strerror(errno)));
  }
  ::close(fd);
  for (const char* name :
       {"excite.db", "excite.db-wal", "excite.db-shm", "excite.lock"}) {
    const std::filesystem::path file = dir / name;
    if (!std::filesystem::exists(file, ec)) continue;
    std::filesystem::permissions(
        file, std::filesystem::perms::owner_read | std::filesystem::perms::owner_write,
        std::filesystem::perm_options::replace, ec);
    if (ec) {
      return absl::FailedPreconditionError(
          absl::StrCat("cannot make ", file.string(), " private (0600): ", ec.message()));
    }
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<std::unique_ptr<SqliteStore>> SqliteStore::Open(
    const std::string& data_dir) {
  if (data_dir.empty()) {
    return absl::InvalidArgumentError("the data directory must not be empty");
  }
  const std::filesystem::path dir(data_dir);
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) {
    return absl::FailedPreconditionError(
        absl::StrCat("cannot create data directory ", data_dir, ": ", ec.message()));
  }
  absl::StatusOr<int> lock_fd = LockDataDir(dir);
  if (!lock_fd.ok()) return lock_fd.status();
  if (absl::Status s = RestrictPermissions(dir); !s.ok()) {
    ::close(*lock_fd);
    return s;
  }

  const std::string path = (dir / "excite.db").string();
  sqlite3* db = nullptr;
  const int rc = sqlite3_open_v2(
      path.c_str(), &db, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_NOMUTEX,
      nullptr);
  if (rc != SQLITE_OK) {
    absl::Status status = SqliteError(db, rc, absl::StrCat("open ", path));
    sqlite3_close(db);
    ::close(*lock_fd);
    return status;
  }
  sqlite3_extended_result_codes(db, 1);
  std::unique_ptr<SqliteStore> store(new SqliteStore(db, path, *lock_fd));
  absl::MutexLock lock(&store->mu_);
  if (absl::Status s = SqliteError(db, sqlite3_busy_timeout(db, 5000), "busy_timeout");
      !s.ok()) {
    return s;
  }
  // journal_mode returns the mode actually in effect: insist on WAL.
  {
    absl::StatusOr<SqliteStatement> stmt =
        SqliteStatement::Prepare(db, "PRAGMA journal_mode=WAL");
    if (!stmt.ok()) return stmt.status();
    absl::StatusOr<bool> row = stmt->Step();
    if (!row.ok()) return row.status();
    if (!*row || stmt->ColumnText(0) != "wal") {
      return absl::FailedPreconditionError(
          absl::StrCat("sqlite: ", path, " could not be switched to WAL mode"));
    }
  }
  if (absl::Status s = store->Exec("PRAGMA synchronous=FULL"); !s.ok()) return s;
  if (absl::Status s = store->InitSchema(); !s.ok()) {
    return absl::Status(s.code(), absl::StrCat(path, ": ", s.message()));
  }
  return store;
}

SqliteStore::SqliteStore(sqlite3* db, std::string path, int lock_fd)
    : db_(db), path_(std::move(path)), lock_fd_(lock_fd) {}

SqliteStore::~SqliteStore() {
  {
    absl::MutexLock lock(&mu_);
    sqlite3_close_v2(db_);
    db_ = nullptr;
  }
  if (lock_fd_ >= 0) ::close(lock_fd_);  // releases the flock
}

absl::Status SqliteStore::Exec(const char* sql) {
  char* error = nullptr;
  const int rc = sqlite3_exec(db_, sql, nullptr, nullptr, &error);
  if (rc == SQLITE_OK) return absl::OkStatus();
  std::string message = error != nullptr ? error : sqlite3_errstr(rc);
  sqlite3_free(error);
  absl::Status status = SqliteError(db_, rc, sql);
  return absl::Status(status.code(), absl::StrCat("sqlite: \"", sql, "\": ", message));
}

absl::Status SqliteStore::Rollback() {
  if (sqlite3_get_autocommit(db_) != 0) return absl::OkStatus();  // nothing open
  return Exec("ROLLBACK");
}

absl::Status SqliteStore::InitSchema() {
  return InTransaction([&]() -> absl::Status {
    absl::StatusOr<SqliteStatement> tables = SqliteStatement::Prepare(
        db_, "SELECT name FROM sqlite_master WHERE type = 'table' ORDER BY name");
    if (!tables.ok()) return tables.status();
    bool has_version_table = false;
    int other_tables = 0;
    while (true) {
      absl::StatusOr<bool> row = tables->Step();
      if (!row.ok()) return row.status();
      if (!*row) break;
      if (tables->ColumnText(0) == "schema_version") {
        has_version_table = true;
      } else {
        ++other_tables;
      }
    }
    if (!has_version_table) {
      if (other_tables > 0) {
        return absl::FailedPreconditionError(
            "the database has tables but no schema_version table: it was not "
            "written by excite-server; refusing to use it");
      }
      if (absl::Status s = Exec(kCreateTables); !s.ok()) return s;
      if (absl::Status s = Exec(kCreateSessionLabels); !s.ok()) return s;
      absl::StatusOr<SqliteStatement> insert = SqliteStatement::Prepare(
          db_, "INSERT INTO schema_version (version) VALUES (?)");
      if (!insert.ok()) return insert.status();
      if (absl::Status s = insert->BindInt64(1, kSchemaVersion); !s.ok()) return s;
      return insert->Step().status();
    }
    absl::StatusOr<SqliteStatement> select =
        SqliteStatement::Prepare(db_, "SELECT version FROM schema_version");
    if (!select.ok()) return select.status();
    std::vector<int64_t> versions;
    while (true) {
      absl::StatusOr<bool> row = select->Step();
      if (!row.ok()) return row.status();
      if (!*row) break;
      versions.push_back(select->ColumnInt64(0));
    }
    if (versions.size() != 1) {
      return absl::DataLossError(absl::StrCat("schema_version has ", versions.size(),
                                              " rows; expected exactly 1"));
    }
    if (versions[0] > kSchemaVersion) {
      return absl::FailedPreconditionError(absl::StrCat(
          "schema version ", versions[0],
          " is newer than the version this "
          "excite-server understands (",
          kSchemaVersion,
          "): it was written by a newer excite-server; upgrade excite-server or use "
          "another --data_dir"));
    }
    if (versions[0] == 1) return MigrateFromVersion1();
    if (versions[0] != kSchemaVersion) {
      return absl::FailedPreconditionError(absl::StrCat("unknown schema version ",
                                                        versions[0],
                                                        " (this excite-server "
                                                        "understands version ",
                                                        kSchemaVersion, ")"));
    }
    return absl::OkStatus();
  });
}

absl::Status SqliteStore::MigrateFromVersion1() {
  // Inside InitSchema's transaction: the upgrade commits whole or not at all.
  if (absl::Status s = Exec(kCreateSessionLabels); !s.ok()) return s;
  return Exec(kMigrateFromVersion1);
}

absl::StatusOr<bool> SqliteStore::SessionExists(const std::string& id) {
  absl::StatusOr<SqliteStatement> stmt =
      SqliteStatement::Prepare(db_, "SELECT 1 FROM sessions WHERE id = ?");
  if (!stmt.ok()) return stmt.status();
  if (absl::Status s = stmt->BindText(1, id); !s.ok()) return s;
  return stmt->Step();
}

absl::Status SqliteStore::InTransaction(absl::FunctionRef<absl::Status()> body) {
  if (absl::Status s = Exec("BEGIN IMMEDIATE"); !s.ok()) return s;
  if (absl::Status s = body(); !s.ok()) {
    Rollback().IgnoreError();  // the original error is the one to report
    return s;
  }
  if (absl::Status s = Exec("COMMIT"); !s.ok()) {
    Rollback().IgnoreError();
    return s;
  }
  return absl::OkStatus();
}

absl::Status SqliteStore::InsertSessionRow(const SessionRecord& session) {
  absl::StatusOr<SqliteStatement> stmt = SqliteStatement::Prepare(
      db_,
      "INSERT INTO sessions (id, config, created_unix_ms, hyperparameters, "
      "model_version, display_name) VALUES (?, ?, ?, ?, ?, ?)");
  if (!stmt.ok()) return stmt.status();
  if (absl::Status s = stmt->BindText(1, session.id); !s.ok()) return s;
  if (absl::Status s = stmt->BindBlob(2, session.config); !s.ok()) return s;
  if (absl::Status s = stmt->BindInt64(3, session.created_unix_ms); !s.ok()) return s;
  if (absl::Status s = stmt->BindBlob(4, session.hyperparameters); !s.ok()) return s;
  if (absl::Status s = stmt->BindInt64(5, session.model_version); !s.ok()) return s;
  if (absl::Status s = stmt->BindText(6, session.display_name); !s.ok()) return s;
  absl::Status status = stmt->Step().status();
  if (absl::IsAlreadyExists(status)) {
    return absl::AlreadyExistsError(
        absl::StrCat("session sessions/", session.id, " already exists"));
  }
  if (!status.ok()) return status;
  absl::StatusOr<SqliteStatement> label = SqliteStatement::Prepare(
      db_, "INSERT INTO session_labels (session_id, key, value) VALUES (?, ?, ?)");
  if (!label.ok()) return label.status();
  for (const auto& [key, value] : session.labels) {
    if (absl::Status s = label->Reset(); !s.ok()) return s;
    if (absl::Status s = label->BindText(1, session.id); !s.ok()) return s;
    if (absl::Status s = label->BindText(2, key); !s.ok()) return s;
    if (absl::Status s = label->BindText(3, value); !s.ok()) return s;
    if (absl::Status s = label->Step().status(); !s.ok()) return s;
  }
  return absl::OkStatus();
}

absl::Status SqliteStore::LoadLabels(std::vector<SessionRecord>* sessions) {
  absl::StatusOr<SqliteStatement> stmt = SqliteStatement::Prepare(
      db_, "SELECT key, value FROM session_labels WHERE session_id = ? ORDER BY key");
  if (!stmt.ok()) return stmt.status();
  for (SessionRecord& session : *sessions) {
    if (absl::Status s = stmt->Reset(); !s.ok()) return s;
    if (absl::Status s = stmt->BindText(1, session.id); !s.ok()) return s;
    while (true) {
      absl::StatusOr<bool> row = stmt->Step();
      if (!row.ok()) return row.status();
      if (!*row) break;
      session.labels[stmt->ColumnText(0)] = stmt->ColumnText(1);
    }
  }
  return absl::OkStatus();
}

absl::Status SqliteStore::InsertSampleRows(const std::string& session_id,
                                           const std::vector<SampleRecord>& batch,
                                           bool ignore_duplicates, InsertResult* result) {
  absl::StatusOr<SqliteStatement> stmt = SqliteStatement::Prepare(
      db_, ignore_duplicates
               ? "INSERT OR IGNORE INTO samples (session_id, sequence, state, input, "
                 "next_state, timestamp_s) VALUES (?, ?, ?, ?, ?, ?)"
               : "INSERT INTO samples (session_id, sequence, state, input, "
                 "next_state, timestamp_s) VALUES (?, ?, ?, ?, ?, ?)");
  if (!stmt.ok()) return stmt.status();
  if (result != nullptr) result->stored.reserve(batch.size());
  for (const SampleRecord& sample : batch) {
    if (absl::Status s = stmt->BindText(1, session_id); !s.ok()) return s;
    if (absl::Status s = stmt->BindInt64(2, sample.sequence); !s.ok()) return s;
    if (absl::Status s = stmt->BindDoubles(3, sample.state); !s.ok()) return s;
    if (absl::Status s = stmt->BindDoubles(4, sample.input); !s.ok()) return s;
    if (absl::Status s = stmt->BindDoubles(5, sample.next_state); !s.ok()) return s;
    if (absl::Status s = stmt->BindDouble(6, sample.timestamp_s); !s.ok()) return s;
    if (absl::Status s = stmt->Step().status(); !s.ok()) {
      return absl::Status(s.code(), absl::StrCat("sample ", sample.sequence, " of ",
                                                 session_id, ": ", s.message()));
    }
    if (result != nullptr) {
      const bool stored = sqlite3_changes(db_) > 0;
      result->stored.push_back(stored);
      ++(stored ? result->stored_count : result->duplicate_count);
    }
    if (absl::Status s = stmt->Reset(); !s.ok()) return s;
  }
  return absl::OkStatus();
}

absl::Status SqliteStore::CreateSession(const SessionRecord& session) {
  absl::MutexLock lock(&mu_);
  return InsertSessionRow(session);
}

absl::Status SqliteStore::ImportSession(const SessionRecord& session,
                                        const std::vector<SampleRecord>& samples) {
  absl::MutexLock lock(&mu_);
  return InTransaction([&]() -> absl::Status {
    if (absl::Status s = InsertSessionRow(session); !s.ok()) return s;
    return InsertSampleRows(session.id, samples, /*ignore_duplicates=*/false, nullptr);
  });
}

absl::Status SqliteStore::DeleteSession(const std::string& id, int64_t /*fence*/) {
  absl::MutexLock lock(&mu_);
  return InTransaction([&]() -> absl::Status {
    for (const char* sql : {"DELETE FROM samples WHERE session_id = ?",
                            "DELETE FROM session_labels WHERE session_id = ?"}) {
      absl::StatusOr<SqliteStatement> rows = SqliteStatement::Prepare(db_, sql);
      if (!rows.ok()) return rows.status();
      if (absl::Status s = rows->BindText(1, id); !s.ok()) return s;
      if (absl::Status s = rows->Step().status(); !s.ok()) return s;
    }
    absl::StatusOr<SqliteStatement> session =
        SqliteStatement::Prepare(db_, "DELETE FROM sessions WHERE id = ?");
    if (!session.ok()) return session.status();
    if (absl::Status s = session->BindText(1, id); !s.ok()) return s;
    if (absl::Status s = session->Step().status(); !s.ok()) return s;
    if (sqlite3_changes(db_) == 0) {
      return absl::NotFoundError(absl::StrCat("session sessions/", id, " not found"));
    }
    return absl::OkStatus();
  });
}

absl::StatusOr<int64_t> SqliteStore::CountSessions() {
  absl::MutexLock lock(&mu_);
  absl::StatusOr<SqliteStatement> stmt =
      SqliteStatement::Prepare(db_, "SELECT count(*) FROM sessions");
  if (!stmt.ok()) return stmt.status();
  absl::StatusOr<bool> row = stmt->Step();
  if (!row.ok()) return row.status();
  return *row ? stmt->ColumnInt64(0) : 0;
}

absl::StatusOr<std::vector<SessionListing>> SqliteStore::ListSessions(
    const std::string& after_id, int limit) {
  absl::MutexLock lock(&mu_);
  absl::StatusOr<SqliteStatement> stmt = SqliteStatement::Prepare(
      db_, absl::StrCat(kSelectSessions, " WHERE id > ? ORDER BY id LIMIT ?"));
  if (!stmt.ok()) return stmt.status();
  if (absl::Status s = stmt->BindText(1, after_id); !s.ok()) return s;
  if (absl::Status s = stmt->BindInt64(2, limit); !s.ok()) return s;
  std::vector<SessionRecord> records;
  while (true) {
    absl::StatusOr<bool> row = stmt->Step();
    if (!row.ok()) return row.status();
    if (!*row) break;
    records.push_back(SessionFromRow(*stmt));
  }
  if (absl::Status s = LoadLabels(&records); !s.ok()) return s;
  absl::StatusOr<SqliteStatement> counts = SqliteStatement::Prepare(
      db_,
      "SELECT count(*), coalesce(max(sequence), -1) FROM samples WHERE session_id = ?");
  if (!counts.ok()) return counts.status();
  std::vector<SessionListing> listings;
  listings.reserve(records.size());
  for (SessionRecord& record : records) {
    if (absl::Status s = counts->Reset(); !s.ok()) return s;
    if (absl::Status s = counts->BindText(1, record.id); !s.ok()) return s;
    absl::StatusOr<bool> row = counts->Step();
    if (!row.ok()) return row.status();
    SessionListing listing;
    listing.sample_count = *row ? counts->ColumnInt64(0) : 0;
    listing.last_sequence = *row ? counts->ColumnInt64(1) : -1;
    listing.record = std::move(record);
    listings.push_back(std::move(listing));
  }
  return listings;
}

absl::StatusOr<SessionListing> SqliteStore::ListSession(const std::string& id) {
  absl::StatusOr<SessionRecord> record = LoadSession(id);
  if (!record.ok()) return record.status();
  absl::MutexLock lock(&mu_);
  absl::StatusOr<SqliteStatement> counts = SqliteStatement::Prepare(
      db_,
      "SELECT count(*), coalesce(max(sequence), -1) FROM samples WHERE session_id = ?");
  if (!counts.ok()) return counts.status();
  if (absl::Status s = counts->BindText(1, id); !s.ok()) return s;
  absl::StatusOr<bool> row = counts->Step();
  if (!row.ok()) return row.status();
  SessionListing listing;
  listing.record = *std::move(record);
  listing.sample_count = *row ? counts->ColumnInt64(0) : 0;
  listing.last_sequence = *row ? counts->ColumnInt64(1) : -1;
  return listing;
}

absl::StatusOr<SessionRecord> SqliteStore::LoadSession(const std::string& id) {
  absl::MutexLock lock(&mu_);
  absl::StatusOr<SqliteStatement> stmt =
      SqliteStatement::Prepare(db_, absl::StrCat(kSelectSessions, " WHERE id = ?"));
  if (!stmt.ok()) return stmt.status();
  if (absl::Status s = stmt->BindText(1, id); !s.ok()) return s;
  absl::StatusOr<bool> row = stmt->Step();
  if (!row.ok()) return row.status();
  if (!*row) {
    return absl::NotFoundError(absl::StrCat("session sessions/", id, " not found"));
  }
  std::vector<SessionRecord> one = {SessionFromRow(*stmt)};
  if (absl::Status s = LoadLabels(&one); !s.ok()) return s;
  return std::move(one.front());
}

absl::StatusOr<std::vector<SampleRecord>> SqliteStore::LoadSamples(
    const std::string& session_id, std::vector<int64_t>* unreadable) {
  absl::MutexLock lock(&mu_);
  absl::StatusOr<SqliteStatement> stmt = SqliteStatement::Prepare(
      db_,
      "SELECT sequence, state, input, next_state, timestamp_s FROM samples WHERE "
      "session_id = ? ORDER BY sequence");
  if (!stmt.ok()) return stmt.status();
  if (absl::Status s = stmt->BindText(1, session_id); !s.ok()) return s;
  std::vector<SampleRecord> samples;
  while (true) {
    absl::StatusOr<bool> row = stmt->Step();
    if (!row.ok()) return row.status();
    if (!*row) break;
    if (absl::Status s = AppendSampleRow(
            session_id, stmt->ColumnInt64(0), stmt->ColumnBlob(1), stmt->ColumnBlob(2),
            stmt->ColumnBlob(3), stmt->ColumnDouble(4), &samples, unreadable);
        !s.ok()) {
      return s;
    }
  }
  return samples;
}

absl::StatusOr<InsertResult> SqliteStore::InsertSamples(
    const std::string& session_id, int64_t /*fence*/,
    const std::vector<SampleRecord>& batch) {
  absl::MutexLock lock(&mu_);
  InsertResult result;
  absl::Status status = InTransaction([&]() -> absl::Status {
    absl::StatusOr<bool> exists = SessionExists(session_id);
    if (!exists.ok()) return exists.status();
    if (!*exists) {
      return absl::NotFoundError(
          absl::StrCat("session sessions/", session_id, " not found"));
    }
    return InsertSampleRows(session_id, batch, /*ignore_duplicates=*/true, &result);
  });
  if (!status.ok()) return status;
  return result;
}

absl::Status SqliteStore::SaveModelState(const std::string& session_id, int64_t /*fence*/,
                                         const std::string& hyperparameters,
                                         int64_t model_version) {
  absl::MutexLock lock(&mu_);
  absl::StatusOr<SqliteStatement> stmt = SqliteStatement::Prepare(
      db_, "UPDATE sessions SET hyperparameters = ?, model_version = ? WHERE id = ?");
  if (!stmt.ok()) return stmt.status();
  if (absl::Status s = stmt->BindBlob(1, hyperparameters); !s.ok()) return s;
  if (absl::Status s = stmt->BindInt64(2, model_version); !s.ok()) return s;
  if (absl::Status s = stmt->BindText(3, session_id); !s.ok()) return s;
  if (absl::Status s = stmt->Step().status(); !s.ok()) return s;
  if (sqlite3_changes(db_) == 0) {
    return absl::NotFoundError(
        absl::StrCat("session sessions/", session_id, " not found"));
  }
  return absl::OkStatus();
}

absl::StatusOr<int64_t> SqliteStore::AcquireLease(const std::string& session_id) {
  absl::MutexLock lock(&mu_);
  absl::StatusOr<bool> exists = SessionExists(session_id);
  if (!exists.ok()) return exists.status();
  if (!*exists) {
    return absl::NotFoundError(
        absl::StrCat("session sessions/", session_id, " not found"));
  }
  return 0;
}

absl::StatusOr<LeaseRenewal> SqliteStore::RenewLeases(
    const std::vector<HeldLease>& /*held*/) {
  return LeaseRenewal();
}

absl::Status SqliteStore::ReleaseLease(const std::string& /*session_id*/,
                                       int64_t /*fence*/) {
  return absl::OkStatus();
}

}  // namespace excite::store
