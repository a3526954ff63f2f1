#ifndef EXCITE_SERVER_SESSION_SESSION_REGISTRY_H_
#define EXCITE_SERVER_SESSION_SESSION_REGISTRY_H_

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/random/random.h"
#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "absl/synchronization/mutex.h"
#include "absl/synchronization/notification.h"
#include "server/session/memory_budget.h"
#include "server/session/metrics_sink.h"
#include "server/session/session.h"
#include "server/session/stored_format.h"
#include "server/store/session_store.h"

namespace excite::session {

struct RegistryOptions {
  // Cap on the sessions the store holds (in a shared store a soft cap: replicas
  // creating at once may pass it by one each).
  int64_t max_sessions = 10000;
  // How the stored config and fit bytes are read and written (required).
  const StoredFormat* format = nullptr;
  // Nullable: no timings recorded / no memory budget. Must outlive the registry.
  MetricsSink* metrics = nullptr;
  MemoryBudget* budget = nullptr;
  // Shared stores only. The lease's duration (the store's); leases are renewed
  // every third of it and trusted here until a sixth of it before they end.
  std::chrono::milliseconds lease_ttl{5000};
  // A session no call used for this long is released (its memory freed, its
  // lease given up); 0: never.
  std::chrono::milliseconds idle_release{std::chrono::minutes(5)};
  // A session another replica asked for is handed over once idle this long.
  std::chrono::milliseconds handoff_idle{500};
};

// The sessions this replica serves, backed by the store. Thread-safe; the
// registry lock is held only for map operations, never while a session works
// or the store is called.
//
// Exclusive store (SQLite): every stored session is loaded at start and served
// here. Shared store (PostgreSQL): a session is loaded on first use after its
// lease was taken (see store::SessionStore), kept while it is used, and dropped
// when its lease is lost (another replica took it after it expired), when
// another replica asked for it and it is idle, or after idle_release; a
// background thread renews the leases. Create, Import and List work on any
// replica and take no lease.
class SessionRegistry {
 public:
  // Exclusive store: loads every stored session and its samples (GPs are rebuilt
  // from the data and fitted lazily at first use); restored sessions count in
  // the budget even beyond it. Shared store: loads nothing, starts renewing.
  // `store` must outlive the registry.
  static absl::StatusOr<std::unique_ptr<SessionRegistry>> Load(store::SessionStore* store,
                                                               RegistryOptions options);
  // Stops renewing and releases every lease held (so that another replica can
  // take the sessions at once).
  ~SessionRegistry();
  SessionRegistry(const SessionRegistry&) = delete;
  SessionRegistry& operator=(const SessionRegistry&) = delete;

  // Creates and stores a session, created now, from a validated spec, display
  // name and labels (the API layer validates them). `session_id` empty: a fresh
  // id is generated. ALREADY_EXISTS for a taken id, RESOURCE_EXHAUSTED beyond
  // max_sessions or the memory budget.
  absl::StatusOr<SessionDescription> Create(const std::string& session_id,
                                            SessionSpec spec,
                                            std::string display_name = "",
                                            Labels labels = {});

  // Creates and stores a session with all its samples and saved hyperparameters
  // (`record` as from a validated SessionArchive; its id and model_version are
  // set here) in one store transaction. `session_id` empty: a fresh id. The
  // session is built as after a restart (Session::Restore). ALREADY_EXISTS for a
  // taken id, RESOURCE_EXHAUSTED beyond max_sessions or the memory budget; on
  // any error nothing is stored or registered.
  absl::StatusOr<SessionDescription> Import(
      const std::string& session_id, store::SessionRecord record,
      const std::vector<store::SampleRecord>& samples);

  // The session, ready to serve. NOT_FOUND "session sessions/x not found". In a
  // shared store, takes its lease and loads it if needed: UNAVAILABLE if another
  // replica serves it (which is asked to hand it over) or the store cannot be
  // reached, RESOURCE_EXHAUSTED if it does not fit the memory budget.
  absl::StatusOr<std::shared_ptr<Session>> Get(const std::string& id);

  // What GetSession answers: the live description of a session served here,
  // else (a shared store) the stored one (Session::DescribeStored), without
  // taking the lease: reading a session never moves it. NOT_FOUND if unknown.
  absl::StatusOr<SessionDescription> Describe(const std::string& id);
  // The session's learning history (Session::History) if it is served here; a
  // session of a shared store served by another replica (or none) has an empty
  // one here. Never takes the lease. NOT_FOUND if unknown.
  absl::StatusOr<LearningHistory> History(const std::string& id);

  // Deletes the session and its samples (store first). NOT_FOUND if unknown.
  absl::Status Delete(const std::string& id);

  struct Page {
    std::vector<SessionDescription> sessions;
    std::string next_page_token;  // empty on the last page
  };
  // Sessions in id order after `page_token` (an opaque token from a previous
  // page) that `matches`, as the store lists them: sessions served here
  // are described live, the others as stored (Session::DescribeStored).
  // page_size: 0 means 50, larger than 1000 means 1000; negative is
  // INVALID_ARGUMENT, as is a token this server did not produce. Every page but
  // the last holds page_size sessions; the last may be empty.
  // `matches` (null: every session) selects by labels.
  using LabelMatcher = std::function<bool(const Labels&)>;
  absl::StatusOr<Page> List(int32_t page_size, const std::string& page_token,
                            const LabelMatcher& matches = nullptr);

  // Sessions loaded here, and their samples.
  int64_t size() const;
  int64_t loaded_samples() const;

 private:
  // One session id this replica has served or is loading.
  struct Entry {
    // Serialises loading and releasing this session.
    absl::Mutex load_mu;
  };
  struct Loaded {
    std::shared_ptr<Entry> entry;
    std::shared_ptr<Session> session;  // null while not loaded
    // Shared stores: the lease is trusted until then.
    std::chrono::steady_clock::time_point valid_until;
  };

  SessionRegistry(store::SessionStore* store, RegistryOptions options);
  absl::Status LoadAll();
  // Exclusive store: Get(id). Shared store: the session if this replica serves it
  // and it is ready, else null (never takes a lease).
  absl::StatusOr<std::shared_ptr<Session>> ServedHere(const std::string& id);
  // The session if loaded, fresh and its lease trusted; else null.
  std::shared_ptr<Session> Ready(const Loaded& loaded) const
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // Get's slow path (shared stores): lease, then load unless loaded under it.
  absl::StatusOr<std::shared_ptr<Session>> AcquireAndLoad(const std::string& id,
                                                          std::shared_ptr<Entry> entry);
  // The stored session `id` under lease `fence`, restored.
  absl::StatusOr<std::shared_ptr<Session>> Restore(const std::string& id, int64_t fence);
  // Takes `bytes` of the budget (RESOURCE_EXHAUSTED naming `what`), releasing
  // idle sessions to make room in a shared store.
  absl::Status Reserve(int64_t bytes, absl::string_view what);
  std::string GenerateId() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // `session_id`, or a generated one if empty, if it is free and the cap allows
  // one more session (ALREADY_EXISTS, RESOURCE_EXHAUSTED otherwise).
  absl::StatusOr<std::string> NewSessionId(const std::string& session_id);
  // Registers a session created or imported here (exclusive stores).
  void Register(const std::shared_ptr<Session>& session, int64_t bytes);
  std::chrono::steady_clock::time_point TrustUntil(
      std::chrono::steady_clock::time_point asked) const;

  // The renewal thread: every lease_ttl / 3, RenewLeases, then drops what was
  // lost and releases what is wanted elsewhere or idle.
  void RenewLoop();
  void RenewOnce();
  // Drops the session `id` if it is still `session` and idle for `idle`
  // (always if `idle` is negative), then releases its lease. OK unless the
  // store failed to release it (logged; the lease then expires); a session not
  // dropped (busy, loading, or no longer the same) is OK too.
  absl::Status Release(const std::string& id, const std::shared_ptr<Session>& session,
                       std::chrono::nanoseconds idle);

  store::SessionStore* const store_;
  const RegistryOptions options_;
  const bool shared_;
  mutable absl::Mutex mu_;
  std::map<std::string, Loaded> sessions_ ABSL_GUARDED_BY(mu_);
  absl::BitGen bitgen_ ABSL_GUARDED_BY(mu_);
  absl::Notification stop_;
  std::thread renewer_;
};

}  // namespace excite::session

#endif  // EXCITE_SERVER_SESSION_SESSION_REGISTRY_H_
