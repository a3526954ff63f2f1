#ifndef EXCITE_SERVER_STORE_SESSION_STORE_H_
#define EXCITE_SERVER_STORE_SESSION_STORE_H_

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "server/store/store_records.h"

namespace excite::store {

// The durable store of sessions and their samples, as the session registry and
// the sessions use it. Implementations: SqliteStore (one process, the embedded
// default) and PostgresStore (many replicas on one database). Every method that
// writes returns only after its transaction is committed: acknowledged means
// durable. Implementations are thread-safe.
//
// Ownership. In a shared store (shared() true) several replicas serve the same
// sessions, one at a time: a replica takes a session's lease (AcquireLease)
// before it loads or writes the session, renews what it holds (RenewLeases)
// and releases it when done. Every lease carries a fencing number that grows
// each time the session changes owner, and every write of a session names the
// fence its writer holds: a write whose lease has expired or was taken over
// fails with UNAVAILABLE and writes nothing, so two replicas never both write
// one session, also when one was paused and comes back. In an exclusive store
// (SQLite: one process holds the directory) this process owns every session:
// leases are granted with fence 0, never lost, and fences are not checked.
class SessionStore {
 public:
  virtual ~SessionStore() = default;

  // Where the data lives, for log lines (a path, or a URL without a password).
  virtual std::string location() const = 0;
  // True if other processes may serve the same sessions (see above).
  virtual bool shared() const = 0;

  // ALREADY_EXISTS if a session with this id is stored. Takes no lease.
  virtual absl::Status CreateSession(const SessionRecord& session) = 0;
  // Stores a whole session (record, including its hyperparameters and model
  // version, and every sample) in ONE transaction: all or nothing. ALREADY_EXISTS
  // if the id is taken; any error (e.g. two samples with one sequence number)
  // rolls everything back. Takes no lease.
  virtual absl::Status ImportSession(const SessionRecord& session,
                                     const std::vector<SampleRecord>& samples) = 0;
  // The number of stored sessions.
  virtual absl::StatusOr<int64_t> CountSessions() = 0;
  // At most `limit` sessions with ids after `after_id` ("" for the first), in id
  // order, with their sample counts. Cost: O(listed sessions) plus an index
  // scan of their samples.
  virtual absl::StatusOr<std::vector<SessionListing>> ListSessions(
      const std::string& after_id, int limit) = 0;
  // One session as ListSessions gives it. NOT_FOUND if there is no such session.
  virtual absl::StatusOr<SessionListing> ListSession(const std::string& id) = 0;
  // One session's record. NOT_FOUND if there is no such session.
  virtual absl::StatusOr<SessionRecord> LoadSession(const std::string& id) = 0;
  // All samples of one session in sequence order. A row whose vectors cannot be
  // decoded is DATA_LOSS, or, with `unreadable`, left out and its sequence number
  // appended there.
  virtual absl::StatusOr<std::vector<SampleRecord>> LoadSamples(
      const std::string& session_id, std::vector<int64_t>* unreadable) = 0;

  // Writes of a session that the caller owns under lease `fence`.
  //
  // Stores `batch` in ONE transaction: a sample whose sequence number is already
  // stored for this session (or earlier in the batch) is a duplicate and is not
  // written again. NOT_FOUND if the session does not exist (nothing is written
  // then).
  virtual absl::StatusOr<InsertResult> InsertSamples(
      const std::string& session_id, int64_t fence,
      const std::vector<SampleRecord>& batch) = 0;
  // Saves the last fitted hyperparameters (opaque bytes) and the model version
  // they belong to. NOT_FOUND if the session does not exist.
  virtual absl::Status SaveModelState(const std::string& session_id, int64_t fence,
                                      const std::string& hyperparameters,
                                      int64_t model_version) = 0;
  // Removes the session, its labels and samples in one transaction. NOT_FOUND if
  // there is no such session.
  virtual absl::Status DeleteSession(const std::string& id, int64_t fence) = 0;

  // Leases. NOT_FOUND for an unknown session; UNAVAILABLE if the store cannot be
  // reached.
  //
  // Takes the session for this replica and returns its fence: the fence it
  // holds already if it is the owner (the lease is renewed), a new one if the
  // session had no owner or its lease expired. UNAVAILABLE naming the owner if
  // another replica holds an unexpired lease; that replica is asked to hand the
  // session over (RenewLeases reports it there).
  virtual absl::StatusOr<int64_t> AcquireLease(const std::string& session_id) = 0;
  // Extends the leases of `held` and reports which were lost (taken over, or the
  // session deleted) and which another replica asked for.
  virtual absl::StatusOr<LeaseRenewal> RenewLeases(
      const std::vector<HeldLease>& held) = 0;
  // Gives the session up (no-op if the lease is no longer this replica's).
  virtual absl::Status ReleaseLease(const std::string& session_id, int64_t fence) = 0;
};

}  // namespace excite::store

#endif  // EXCITE_SERVER_STORE_SESSION_STORE_H_
