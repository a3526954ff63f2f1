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
// default). Every method that writes returns only after its transaction is
// committed: acknowledged means durable. Implementations are thread-safe.
class SessionStore {
 public:
  virtual ~SessionStore() = default;

  // Where the data lives, for log lines (a path or a URL without its password).
  virtual std::string location() const = 0;

  // ALREADY_EXISTS if a session with this id is stored.
  virtual absl::Status CreateSession(const SessionRecord& session) = 0;
  // Removes the session and all its samples in one transaction. NOT_FOUND if
  // there is no such session.
  virtual absl::Status DeleteSession(const std::string& id) = 0;
  // All sessions in id order.
  virtual absl::StatusOr<std::vector<SessionRecord>> LoadSessions() = 0;
  // One session's record. NOT_FOUND if there is no such session.
  virtual absl::StatusOr<SessionRecord> LoadSession(const std::string& id) = 0;
  // All samples of one session in sequence order. A row whose vectors cannot be
  // decoded is DATA_LOSS, or, with `unreadable`, left out and its sequence number
  // appended there.
  virtual absl::StatusOr<std::vector<SampleRecord>> LoadSamples(
      const std::string& session_id, std::vector<int64_t>* unreadable = nullptr) = 0;

  // Stores `batch` in ONE transaction: a sample whose sequence number is already
  // stored for this session (or earlier in the batch) is a duplicate and is not
  // written again. NOT_FOUND if the session does not exist (nothing is written
  // then).
  virtual absl::StatusOr<InsertResult> InsertSamples(
      const std::string& session_id, const std::vector<SampleRecord>& batch) = 0;

  // Stores a whole session (record, including its hyperparameters and model
  // version, and every sample) in ONE transaction: all or nothing. ALREADY_EXISTS
  // if the id is taken; any error (e.g. two samples with one sequence number)
  // rolls everything back.
  virtual absl::Status ImportSession(const SessionRecord& session,
                                     const std::vector<SampleRecord>& samples) = 0;

  // Saves the last fitted hyperparameters (opaque bytes) and the model version
  // they belong to. NOT_FOUND if the session does not exist.
  virtual absl::Status SaveModelState(const std::string& session_id,
                                      const std::string& hyperparameters,
                                      int64_t model_version) = 0;
};

}  // namespace excite::store

#endif  // EXCITE_SERVER_STORE_SESSION_STORE_H_
