#include "server/store/sqlite_statement.h"

#include <sqlite3.h>

#include <utility>

#include "absl/strings/str_cat.h"
#include "server/store/double_blob.h"

namespace excite::store {
namespace {

absl::StatusCode CodeFor(int code) {
  if (code == SQLITE_CONSTRAINT_PRIMARYKEY || code == SQLITE_CONSTRAINT_UNIQUE) {
    return absl::StatusCode::kAlreadyExists;
  }
  switch (code & 0xff) {  // primary result code
    case SQLITE_CONSTRAINT:
      return absl::StatusCode::kInvalidArgument;
    case SQLITE_BUSY:
    case SQLITE_LOCKED:
      return absl::StatusCode::kUnavailable;
    case SQLITE_FULL:
    case SQLITE_NOMEM:
      return absl::StatusCode::kResourceExhausted;
    case SQLITE_CORRUPT:
    case SQLITE_NOTADB:
      return absl::StatusCode::kDataLoss;
    case SQLITE_CANTOPEN:
    case SQLITE_PERM:
    case SQLITE_READONLY:
      return absl::StatusCode::kFailedPrecondition;
    default:
      return absl::StatusCode::kInternal;
  }
}

}  // namespace

absl::Status SqliteError(sqlite3* db, int code, absl::string_view context) {
  if (code == SQLITE_OK || code == SQLITE_ROW || code == SQLITE_DONE) {
    return absl::OkStatus();
  }
  const char* message = db != nullptr ? sqlite3_errmsg(db) : sqlite3_errstr(code);
  return absl::Status(CodeFor(code), absl::StrCat("sqlite: ", context, ": ", message,
                                                  " (code ", code, ")"));
}

absl::StatusOr<SqliteStatement> SqliteStatement::Prepare(sqlite3* db,
                                                         absl::string_view sql) {
  sqlite3_stmt* stmt = nullptr;
  const int rc =
      sqlite3_prepare_v2(db, sql.data(), static_cast<int>(sql.size()), &stmt, nullptr);
  if (rc != SQLITE_OK) {
    sqlite3_finalize(stmt);
    return SqliteError(db, rc, absl::StrCat("prepare \"", sql, "\""));
  }
  return SqliteStatement(db, stmt, std::string(sql));
}

SqliteStatement::SqliteStatement(sqlite3* db, sqlite3_stmt* stmt, std::string sql)
    : db_(db), stmt_(stmt), sql_(std::move(sql)) {}

SqliteStatement::SqliteStatement(SqliteStatement&& other) noexcept
    : db_(other.db_),
      stmt_(std::exchange(other.stmt_, nullptr)),
      sql_(std::move(other.sql_)) {}

SqliteStatement& SqliteStatement::operator=(SqliteStatement&& other) noexcept {
  if (this != &other) {
    sqlite3_finalize(stmt_);
    db_ = other.db_;
    stmt_ = std::exchange(other.stmt_, nullptr);
    sql_ = std::move(other.sql_);
  }
  return *this;
}

SqliteStatement::~SqliteStatement() { sqlite3_finalize(stmt_); }

absl::Status SqliteStatement::BindText(int index, absl::string_view text) {
  return SqliteError(db_,
                     sqlite3_bind_text(stmt_, index, text.data(),
                                       static_cast<int>(text.size()), SQLITE_TRANSIENT),
                     absl::StrCat("bind ", index, " of \"", sql_, "\""));
}

absl::Status SqliteStatement::BindBlob(int index, absl::string_view bytes) {
  // A zero-length blob must still be a blob, not NULL: pass a non-null pointer.
  static const char kEmpty = 0;
  const char* data = bytes.empty() ? &kEmpty : bytes.data();
  return SqliteError(db_,
                     sqlite3_bind_blob(stmt_, index, data, static_cast<int>(bytes.size()),
                                       SQLITE_TRANSIENT),
                     absl::StrCat("bind ", index, " of \"", sql_, "\""));
}

absl::Status SqliteStatement::BindDoubles(int index, const std::vector<double>& values) {
  return BindBlob(index, EncodeDoubles(values));
}

absl::Status SqliteStatement::BindInt64(int index, int64_t value) {
  return SqliteError(db_, sqlite3_bind_int64(stmt_, index, value),
                     absl::StrCat("bind ", index, " of \"", sql_, "\""));
}

absl::Status SqliteStatement::BindDouble(int index, double value) {
  return SqliteError(db_, sqlite3_bind_double(stmt_, index, value),
                     absl::StrCat("bind ", index, " of \"", sql_, "\""));
}

absl::StatusOr<bool> SqliteStatement::Step() {
  const int rc = sqlite3_step(stmt_);
  if (rc == SQLITE_ROW) return true;
  if (rc == SQLITE_DONE) return false;
  return SqliteError(db_, rc, absl::StrCat("step \"", sql_, "\""));
}

absl::Status SqliteStatement::Reset() {
  const int rc = sqlite3_reset(stmt_);
  sqlite3_clear_bindings(stmt_);
  return SqliteError(db_, rc, absl::StrCat("reset \"", sql_, "\""));
}

std::string SqliteStatement::ColumnText(int column) const {
  const unsigned char* text = sqlite3_column_text(stmt_, column);
  const int size = sqlite3_column_bytes(stmt_, column);
  if (text == nullptr) return std::string();
  return std::string(reinterpret_cast<const char*>(text), static_cast<size_t>(size));
}

std::string SqliteStatement::ColumnBlob(int column) const {
  const void* blob = sqlite3_column_blob(stmt_, column);
  const int size = sqlite3_column_bytes(stmt_, column);
  if (blob == nullptr || size <= 0) return std::string();
  return std::string(static_cast<const char*>(blob), static_cast<size_t>(size));
}

int64_t SqliteStatement::ColumnInt64(int column) const {
  return sqlite3_column_int64(stmt_, column);
}

double SqliteStatement::ColumnDouble(int column) const {
  return sqlite3_column_double(stmt_, column);
}

}  // namespace excite::store
