#ifndef EXCITE_SERVER_STORE_SQLITE_STORE_H_
#define EXCITE_SERVER_STORE_SQLITE_STORE_H_

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/functional/function_ref.h"
#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"
#include "server/store/session_store.h"
#include "server/store/store_records.h"

struct sqlite3;

namespace excite::store {

// The embedded SessionStore: one SQLite database
// `<data_dir>/excite.db` in WAL mode with synchronous=FULL, so every method that
// writes returns only after its transaction is committed to disk.
//
// Tables: schema_version(version), sessions(id, config, created_unix_ms,
// hyperparameters, model_version, display_name), session_labels(session_id, key,
// value) with PRIMARY KEY(session_id, key), samples(session_id, sequence, state,
// input, next_state, timestamp_s) with PRIMARY KEY(session_id, sequence). Vectors of
// doubles are stored as blobs of IEEE-754 little-endian doubles.
//
// Thread-safe: one connection behind a mutex (writes are serialised anyway by
// SQLite). Every SQLite error becomes an absl::Status carrying SQLite's message.
class SqliteStore final : public SessionStore {
 public:
  // The schema version this build reads and writes.
  // Version 1 (before display names and labels) is migrated in place at Open.
  static constexpr int kSchemaVersion = 2;

  // Creates `data_dir` (and parents) if needed, opens or creates excite.db and its
  // schema. FAILED_PRECONDITION if the database has a schema version this build
  // does not know (e.g. written by a newer excite-server) or if another store
  // (in this or another process) has the directory open: an exclusive flock on
  // <data_dir>/excite.lock is held for the store's lifetime. The files are made
  // 0600 and the directory 0700 (if the server's user owns it), whatever the
  // umask.
  static absl::StatusOr<std::unique_ptr<SqliteStore>> Open(const std::string& data_dir);

  ~SqliteStore() override;
  SqliteStore(const SqliteStore&) = delete;
  SqliteStore& operator=(const SqliteStore&) = delete;

  // Path of the database file.
  std::string location() const override { return path_; }

  // SessionStore. InsertSamples uses INSERT OR IGNORE; it and ImportSession cost
  // O(rows) inserts plus one fsync. Exclusive: fences are not checked, every
  // lease of a stored session is granted with fence 0 and never lost.
  bool shared() const override { return false; }
  absl::Status CreateSession(const SessionRecord& session) override;
  absl::Status ImportSession(const SessionRecord& session,
                             const std::vector<SampleRecord>& samples) override;
  absl::StatusOr<int64_t> CountSessions() override;
  absl::StatusOr<std::vector<SessionListing>> ListSessions(const std::string& after_id,
                                                           int limit) override;
  absl::StatusOr<SessionListing> ListSession(const std::string& id) override;
  absl::StatusOr<SessionRecord> LoadSession(const std::string& id) override;
  absl::StatusOr<std::vector<SampleRecord>> LoadSamples(
      const std::string& session_id, std::vector<int64_t>* unreadable) override;
  absl::StatusOr<InsertResult> InsertSamples(
      const std::string& session_id, int64_t fence,
      const std::vector<SampleRecord>& batch) override;
  absl::Status SaveModelState(const std::string& session_id, int64_t fence,
                              const std::string& hyperparameters,
                              int64_t model_version) override;
  absl::Status DeleteSession(const std::string& id, int64_t fence) override;
  absl::StatusOr<int64_t> AcquireLease(const std::string& session_id) override;
  absl::StatusOr<LeaseRenewal> RenewLeases(const std::vector<HeldLease>& held) override;
  absl::Status ReleaseLease(const std::string& session_id, int64_t fence) override;

 private:
  SqliteStore(sqlite3* db, std::string path, int lock_fd);

  absl::Status Exec(const char* sql) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  absl::Status InitSchema() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  absl::StatusOr<bool> SessionExists(const std::string& id)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  absl::Status Rollback() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // BEGIN IMMEDIATE, `body`, COMMIT; ROLLBACK (and body's error) if it fails.
  absl::Status InTransaction(absl::FunctionRef<absl::Status()> body)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // INSERT of one sessions row (ALREADY_EXISTS "session sessions/x already exists").
  absl::Status InsertSessionRow(const SessionRecord& session)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // Fills `sessions`' labels from session_labels.
  absl::Status LoadLabels(std::vector<SessionRecord>* sessions)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // Version 1 -> 2: display_name and session_labels.
  absl::Status MigrateFromVersion1() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // INSERT (OR IGNORE if `ignore_duplicates`) of samples rows; `result` (may be
  // null) records which were new.
  absl::Status InsertSampleRows(const std::string& session_id,
                                const std::vector<SampleRecord>& batch,
                                bool ignore_duplicates, InsertResult* result)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);

  absl::Mutex mu_;
  sqlite3* db_ ABSL_GUARDED_BY(mu_);
  const std::string path_;
  const int lock_fd_;  // flock on <data_dir>/excite.lock, held while open
};

}  // namespace excite::store

#endif  // EXCITE_SERVER_STORE_SQLITE_STORE_H_
