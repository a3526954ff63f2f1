#ifndef EXCITE_SERVER_SERVICE_SESSION_REGISTRY_H_
#define EXCITE_SERVER_SERVICE_SESSION_REGISTRY_H_

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/random/random.h"
#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "absl/synchronization/mutex.h"
#include "excite/v1/session_config.pb.h"
#include "server/service/memory_budget.h"
#include "server/service/session.h"
#include "server/store/session_store.h"

namespace excite::service {

// All sessions of the server by id, backed by the store. Thread-safe; the
// registry lock is held only for map operations and session creation, never
// while a session works.
class SessionRegistry {
 public:
  // Loads every stored session and its samples (GPs are rebuilt from the data and
  // fitted lazily at first use). `store`, `metrics` (nullable: no timings
  // recorded) and `budget` (nullable: no memory budget) must outlive the
  // registry. Restored sessions count in the budget even beyond it.
  static absl::StatusOr<std::unique_ptr<SessionRegistry>> Load(
      store::SessionStore* store, int64_t max_sessions, Metrics* metrics = nullptr,
      MemoryBudget* budget = nullptr);

  // Creates and stores a session, created now. `session_id` empty: a fresh id is
  // generated. INVALID_ARGUMENT for a malformed id, config (field path under
  // "config"), display name or labels, with every problem at once; ALREADY_EXISTS
  // for a taken id, RESOURCE_EXHAUSTED beyond max_sessions or the memory budget.
  absl::StatusOr<std::shared_ptr<Session>> Create(
      const std::string& session_id, const v1::SessionConfig& config,
      const std::string& display_name = "",
      const google::protobuf::Map<std::string, std::string>& labels = {});

  // Creates and stores a session with all its samples and saved hyperparameters
  // (`record` as from a validated SessionArchive; its id and model_version are
  // set here) in one store transaction. `session_id` empty: a fresh id. The
  // session is built as after a restart (Session::Restore). ALREADY_EXISTS for a
  // taken id, RESOURCE_EXHAUSTED beyond max_sessions or the memory budget; on
  // any error nothing is stored or registered.
  absl::StatusOr<std::shared_ptr<Session>> Import(
      const std::string& session_id, store::SessionRecord record,
      const std::vector<store::SampleRecord>& samples);

  // NOT_FOUND "session sessions/x not found".
  absl::StatusOr<std::shared_ptr<Session>> Get(const std::string& id) const;

  // Deletes the session and its samples (store first). NOT_FOUND if unknown.
  absl::Status Delete(const std::string& id);

  struct Page {
    std::vector<std::shared_ptr<Session>> sessions;
    std::string next_page_token;  // empty on the last page
  };
  // Sessions in id order after `page_token` (an opaque token from a previous
  // page) that `filter` matches. page_size: 0 means 50, larger than 1000 means
  // 1000; negative is INVALID_ARGUMENT, as is a token this server did not produce.
  // Every page but the last holds page_size sessions; the last may be empty.
  absl::StatusOr<Page> List(int32_t page_size, const std::string& page_token,
                            const LabelFilter& filter = LabelFilter()) const;

  int64_t size() const;

 private:
  SessionRegistry(store::SessionStore* store, int64_t max_sessions, Metrics* metrics,
                  MemoryBudget* budget);
  // budget_->Reserve, or OK without a budget.
  absl::Status Reserve(int64_t bytes, absl::string_view what);
  std::string GenerateId() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // `session_id`, or a generated one if empty, if it is free and the cap allows
  // one more session (ALREADY_EXISTS, RESOURCE_EXHAUSTED otherwise).
  absl::StatusOr<std::string> NewSessionId(const std::string& session_id)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);

  store::SessionStore* const store_;
  const int64_t max_sessions_;
  Metrics* const metrics_;
  MemoryBudget* const budget_;
  mutable absl::Mutex mu_;
  std::map<std::string, std::shared_ptr<Session>> sessions_ ABSL_GUARDED_BY(mu_);
  absl::BitGen bitgen_ ABSL_GUARDED_BY(mu_);
};

}  // namespace excite::service

#endif  // EXCITE_SERVER_SERVICE_SESSION_REGISTRY_H_
