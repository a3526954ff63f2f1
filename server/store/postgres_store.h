#ifndef EXCITE_SERVER_STORE_POSTGRES_STORE_H_
#define EXCITE_SERVER_STORE_POSTGRES_STORE_H_

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "server/store/postgres_connections.h"
#include "server/store/session_store.h"

namespace excite::store {

struct PostgresStoreOptions {
  // libpq connection string or URL ("postgresql://user@host:5432/excite"),
  // checked by ParsePostgresTarget: no password in it.
  std::string url;
  // The password (from a file or the environment; empty: libpq's own sources,
  // e.g. ~/.pgpass, or none).
  std::string password;
  // This replica's name in the leases it holds: unique per process (a restarted
  // replica must not pass for its former self).
  std::string owner;
  // How long a lease lasts unless renewed (the registry renews at a third of
  // it). A replica that dies loses its sessions this long after its last
  // renewal.
  std::chrono::milliseconds lease_ttl{5000};
  // Connections kept open (each serves one call at a time).
  int connections = 4;
  // How long Open keeps trying to reach the server before it gives up.
  std::chrono::milliseconds connect_timeout{30000};
};

// The SessionStore of many replicas: one PostgreSQL database (tested with
// Debian's PostgreSQL 15, through libpqxx). Every write is one transaction
// committed with the server's synchronous_commit (on by default): acknowledged
// means committed. Shared: the leases live in the sessions table (owner, fence,
// lease_expires, handoff_wanted_by), timed by the database's clock, and every
// write takes the session row FOR SHARE and checks owner, fence and expiry in
// the same transaction, so a takeover (which updates that row) waits for a
// write in flight and a write after it fails.
//
// Tables: schema_version(version), sessions(id, config, created_unix_ms,
// hyperparameters, model_version, display_name, owner, fence, lease_expires,
// handoff_wanted_by), session_labels(session_id, key, value), samples(session_id,
// sequence, state, input, next_state, timestamp_s); labels and samples go with
// their session (ON DELETE CASCADE). Vectors are bytea of little-endian doubles,
// as in SQLite. The schema is created on first start (one replica at a time,
// under an advisory lock) and versioned; a newer version is refused.
//
// Errors: an unreachable server, a connection lost mid-call, a lock or
// statement timeout and a server shutting down are UNAVAILABLE (retry); a
// commit whose outcome is unknown is UNAVAILABLE too, and the caller must
// assume either outcome (sample sequence numbers make the retry safe).
// Connections are reopened on the next call, so the store recovers from a
// server restart by itself. Thread-safe.
class PostgresStore final : public SessionStore {
 public:
  // The schema version this build reads and writes.
  static constexpr int kSchemaVersion = 1;

  // Connects (retrying for options.connect_timeout), creates or checks the
  // schema. UNAVAILABLE if the server cannot be reached in time,
  // FAILED_PRECONDITION for a schema this build does not know or a database
  // that holds other tables of these names, INVALID_ARGUMENT for bad options.
  static absl::StatusOr<std::unique_ptr<PostgresStore>> Open(
      const PostgresStoreOptions& options);

  const std::string& owner() const { return options_.owner; }

  std::string location() const override { return location_; }
  bool shared() const override { return true; }
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
  PostgresStore(PostgresStoreOptions options, std::string location,
                std::unique_ptr<PostgresConnections> connections);

  absl::Status InitSchema();

  const PostgresStoreOptions options_;
  const std::string location_;
  const std::unique_ptr<PostgresConnections> connections_;
};

}  // namespace excite::store

#endif  // EXCITE_SERVER_STORE_POSTGRES_STORE_H_
