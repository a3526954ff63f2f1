#ifndef EXCITE_SERVER_STORE_SQLITE_STATEMENT_H_
#define EXCITE_SERVER_STORE_SQLITE_STATEMENT_H_

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

struct sqlite3;
struct sqlite3_stmt;

namespace excite::store {

// Maps a SQLite result code to an absl::Status carrying `context` and the
// connection's error message. SQLITE_OK / SQLITE_ROW / SQLITE_DONE map to OK.
absl::Status SqliteError(sqlite3* db, int code, absl::string_view context);

// A prepared statement (RAII). Not thread-safe: used under the store's mutex.
class SqliteStatement {
 public:
  static absl::StatusOr<SqliteStatement> Prepare(sqlite3* db, absl::string_view sql);

  SqliteStatement(SqliteStatement&& other) noexcept;
  SqliteStatement& operator=(SqliteStatement&& other) noexcept;
  SqliteStatement(const SqliteStatement&) = delete;
  SqliteStatement& operator=(const SqliteStatement&) = delete;
  ~SqliteStatement();

  // Parameters are 1-based as in SQLite.
  absl::Status BindText(int index, absl::string_view text);
  absl::Status BindBlob(int index, absl::string_view bytes);
  absl::Status BindDoubles(int index, const std::vector<double>& values);
  absl::Status BindInt64(int index, int64_t value);
  absl::Status BindDouble(int index, double value);

  // Runs one step: true if a row is available, false when done.
  absl::StatusOr<bool> Step();
  // Resets for re-execution with new bindings (bindings are cleared).
  absl::Status Reset();

  // Columns are 0-based as in SQLite; valid after Step() returned true.
  std::string ColumnText(int column) const;
  std::string ColumnBlob(int column) const;
  int64_t ColumnInt64(int column) const;
  double ColumnDouble(int column) const;

 private:
  SqliteStatement(sqlite3* db, sqlite3_stmt* stmt, std::string sql);
  sqlite3* db_ = nullptr;
  sqlite3_stmt* stmt_ = nullptr;
  std::string sql_;
};

}  // namespace excite::store

#endif  // EXCITE_SERVER_STORE_SQLITE_STATEMENT_H_
