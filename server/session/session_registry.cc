#include "server/session/session_registry.h"

#include <algorithm>
#include <utility>

#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/time/clock.h"
#include "common/logging.h"
#include "server/session/memory_budget.h"
#include "server/session/session_name.h"

namespace excite::session {
namespace {

using Clock = std::chrono::steady_clock;

constexpr int32_t kDefaultPageSize = 50;
constexpr int32_t kMaxPageSize = 1000;
// Sessions read from the store per query while listing or loading.
constexpr int kStoreBatch = 200;
// Page tokens are "v1:" + the last id returned, web-safe base64 encoded.
constexpr absl::string_view kTokenPrefix = "v1:";

std::string EncodeToken(const std::string& last_id) {
  return absl::WebSafeBase64Escape(absl::StrCat(kTokenPrefix, last_id));
}

absl::StatusOr<std::string> DecodeToken(const std::string& token) {
  std::string decoded;
  if (!absl::WebSafeBase64Unescape(token, &decoded) ||
      decoded.compare(0, kTokenPrefix.size(), kTokenPrefix.data(), kTokenPrefix.size()) !=
          0 ||
      !IsValidSessionId(absl::string_view(decoded).substr(kTokenPrefix.size()))) {
    return absl::InvalidArgumentError(
        "page_token: not a token returned by ListSessions (pass next_page_token "
        "unchanged, or empty for the first page)");
  }
  return decoded.substr(kTokenPrefix.size());
}

// Rows that cannot be read set their session aside, not the server.
absl::Status UnreadableRows(const std::vector<int64_t>& unreadable) {
  if (unreadable.empty()) return absl::OkStatus();
  return absl::DataLossError(absl::StrCat(
      unreadable.size(), " stored samples cannot be read (sequence ",
      absl::StrJoin(unreadable.begin(),
                    unreadable.begin() + std::min<size_t>(unreadable.size(), 5), ", "),
      unreadable.size() > 5 ? ", ..." : "", ")"));
}

}  // namespace

SessionRegistry::SessionRegistry(store::SessionStore* store, RegistryOptions options)
    : store_(store), options_(options), shared_(store->shared()) {}

absl::StatusOr<std::unique_ptr<SessionRegistry>> SessionRegistry::Load(
    store::SessionStore* store, RegistryOptions options) {
  std::unique_ptr<SessionRegistry> registry(new SessionRegistry(store, options));
  if (registry->shared_) {
    registry->renewer_ = std::thread([r = registry.get()]() { r->RenewLoop(); });
    return registry;
  }
  if (absl::Status s = registry->LoadAll(); !s.ok()) return s;
  return registry;
}

SessionRegistry::~SessionRegistry() {
  stop_.Notify();
  if (renewer_.joinable()) renewer_.join();
  if (!shared_) return;
  std::vector<std::pair<std::string, std::shared_ptr<Session>>> held;
  {
    absl::MutexLock lock(&mu_);
    for (auto& [id, loaded] : sessions_) {
      if (loaded.session != nullptr) held.emplace_back(id, loaded.session);
    }
  }
  // One by one; if the store is unreachable, the rest of the leases simply
  // expire (no point waiting for each).
  for (const auto& [id, session] : held) {
    if (!Release(id, session, std::chrono::nanoseconds(-1)).ok()) break;
  }
}

absl::Status SessionRegistry::LoadAll() {
  std::string after;
  while (true) {
    absl::StatusOr<std::vector<store::SessionListing>> batch =
        store_->ListSessions(after, kStoreBatch);
    if (!batch.ok()) return batch.status();
    if (batch->empty()) return absl::OkStatus();
    for (const store::SessionListing& listing : *batch) {
      after = listing.record.id;
      absl::StatusOr<std::shared_ptr<Session>> session = Restore(after, /*fence=*/0);
      if (!session.ok()) return session.status();
      const int64_t n = (*session)->Snapshot().sample_count;
      Log(LogLevel::kInfo,
          absl::StrCat("loaded ", (*session)->name(), " with ", n, " samples"));
      int64_t bytes = 0;
      if (options_.budget != nullptr) {
        // Stored already: counted even beyond the budget, which then refuses
        // growth.
        bytes = (*session)->EstimatedBytes(n);
        options_.budget->ForceReserve(bytes);
      }
      Register(*session, bytes);
    }
  }
}

absl::StatusOr<std::shared_ptr<Session>> SessionRegistry::Restore(const std::string& id,
                                                                  int64_t fence) {
  absl::StatusOr<store::SessionRecord> record = store_->LoadSession(id);
  if (!record.ok()) return record.status();
  std::vector<int64_t> unreadable;
  absl::StatusOr<std::vector<store::SampleRecord>> samples =
      store_->LoadSamples(id, &unreadable);
  if (!samples.ok()) return samples.status();
  return Session::Restore(*record, *samples, options_.format, store_, fence,
                          UnreadableRows(unreadable));
}

void SessionRegistry::Register(const std::shared_ptr<Session>& session, int64_t bytes) {
  session->AttachMetrics(options_.metrics);
  session->AttachMemoryBudget(options_.budget, bytes);
  absl::MutexLock lock(&mu_);
  Loaded& loaded = sessions_[session->id()];
  if (loaded.entry == nullptr) loaded.entry = std::make_shared<Entry>();
  loaded.session = session;
  loaded.valid_until = Clock::time_point::max();
}

std::string SessionRegistry::GenerateId() {
  static constexpr char kAlphabet[] = "0123456789abcdefghijklmnopqrstuvwxyz";
  while (true) {
    std::string id = "s-";
    for (int i = 0; i < 12; ++i) {
      id.push_back(kAlphabet[absl::Uniform<size_t>(bitgen_, 0, sizeof(kAlphabet) - 1)]);
    }
    // Shared stores: 36^12 ids make a clash with another replica's unlikely, and
    // the store refuses it (ALREADY_EXISTS) should it happen.
    if (sessions_.find(id) == sessions_.end()) return id;
  }
}

absl::StatusOr<std::string> SessionRegistry::NewSessionId(const std::string& session_id) {
  int64_t held = 0;
  std::string id;
  {
    absl::MutexLock lock(&mu_);
    id = session_id.empty() ? GenerateId() : session_id;
    auto it = sessions_.find(id);
    if (it != sessions_.end() && it->second.session != nullptr && !shared_) {
      return absl::AlreadyExistsError(
          absl::StrCat("session ", SessionName(id), " already exists"));
    }
    held = static_cast<int64_t>(sessions_.size());
  }
  if (shared_) {
    absl::StatusOr<int64_t> count = store_->CountSessions();
    if (!count.ok()) return count.status();
    held = *count;
  }
  if (held >= options_.max_sessions) {
    return absl::ResourceExhaustedError(
        absl::StrCat("the store holds ", held,
                     " sessions, its cap (--max_sessions): delete one first"));
  }
  return id;
}

absl::StatusOr<SessionDescription> SessionRegistry::Create(const std::string& session_id,
                                                           SessionSpec spec,
                                                           std::string display_name,
                                                           Labels labels) {
  Session::Metadata metadata{std::move(display_name), std::move(labels),
                             absl::ToUnixMillis(absl::Now())};

  absl::StatusOr<std::string> id = NewSessionId(session_id);
  if (!id.ok()) return id.status();
  absl::StatusOr<std::shared_ptr<Session>> session =
      Session::Create(*id, std::move(spec), metadata, options_.format, store_);
  if (!session.ok()) return session.status();
  // A shared store's new session is loaded by the replica its calls reach.
  const int64_t bytes = shared_ ? 0 : (*session)->EstimatedBytes(0);
  if (absl::Status s = Reserve(bytes, absl::StrCat("a new session ", SessionName(*id)));
      !s.ok()) {
    return s;
  }
  store::SessionRecord record;
  record.id = *id;
  record.config = (*session)->spec().config;
  record.created_unix_ms = metadata.created_unix_ms;
  record.display_name = metadata.display_name;
  record.labels = metadata.labels;
  if (absl::Status s = store_->CreateSession(record); !s.ok()) {
    if (options_.budget != nullptr) options_.budget->Release(bytes);
    return s;
  }
  if (!shared_) Register(*session, bytes);
  return (*session)->Describe();
}

absl::StatusOr<SessionDescription> SessionRegistry::Import(
    const std::string& session_id, store::SessionRecord record,
    const std::vector<store::SampleRecord>& samples) {
  absl::StatusOr<std::string> id = NewSessionId(session_id);
  if (!id.ok()) return id.status();
  record.id = *id;
  record.model_version = 0;
  // Built in memory first (as after a restart: the hyperparameters seed the first
  // refit), stored second: a failure of either leaves nothing behind.
  absl::StatusOr<std::shared_ptr<Session>> session =
      Session::Restore(record, samples, options_.format, store_);
  if (!session.ok()) return session.status();
  const int64_t bytes =
      shared_ ? 0 : (*session)->EstimatedBytes(static_cast<int64_t>(samples.size()));
  if (absl::Status s = Reserve(bytes, absl::StrCat("importing ", SessionName(*id),
                                                   " with ", samples.size(), " samples"));
      !s.ok()) {
    return s;
  }
  if (absl::Status s = store_->ImportSession(record, samples); !s.ok()) {
    if (options_.budget != nullptr) options_.budget->Release(bytes);
    return s;
  }
  if (!shared_) Register(*session, bytes);
  return (*session)->Describe();
}

absl::Status SessionRegistry::Reserve(int64_t bytes, absl::string_view what) {
  if (options_.budget == nullptr || bytes == 0) return absl::OkStatus();
  absl::Status reserved = options_.budget->Reserve(bytes, what);
  if (reserved.ok() || !shared_) return reserved;
  // Make room: release idle sessions, the longest idle first.
  std::vector<std::pair<std::string, std::shared_ptr<Session>>> idle;
  {
    absl::MutexLock lock(&mu_);
    for (const auto& [id, loaded] : sessions_) {
      if (loaded.session != nullptr && loaded.session->IdleFor(options_.handoff_idle)) {
        idle.emplace_back(id, loaded.session);
      }
    }
  }
  for (const auto& [id, session] : idle) {
    Release(id, session, options_.handoff_idle).IgnoreError();  // logged
    reserved = options_.budget->Reserve(bytes, what);
    if (reserved.ok()) return reserved;
  }
  return reserved;
}

std::chrono::steady_clock::time_point SessionRegistry::TrustUntil(
    Clock::time_point asked) const {
  return asked + options_.lease_ttl - options_.lease_ttl / 6;
}

std::shared_ptr<Session> SessionRegistry::Ready(const Loaded& loaded) const {
  if (loaded.session == nullptr || loaded.session->stale()) return nullptr;
  if (Clock::now() >= loaded.valid_until) return nullptr;
  return loaded.session;
}

absl::StatusOr<std::shared_ptr<Session>> SessionRegistry::Get(const std::string& id) {
  std::shared_ptr<Entry> entry;
  {
    absl::MutexLock lock(&mu_);
    auto it = sessions_.find(id);
    if (!shared_) {
      if (it == sessions_.end() || it->second.session == nullptr) {
        return absl::NotFoundError(
            absl::StrCat("session ", SessionName(id), " not found"));
      }
      return it->second.session;
    }
    if (it != sessions_.end()) {
      if (std::shared_ptr<Session> ready = Ready(it->second)) return ready;
    } else {
      it = sessions_.emplace(id, Loaded{}).first;
    }
    if (it->second.entry == nullptr) it->second.entry = std::make_shared<Entry>();
    entry = it->second.entry;
  }
  return AcquireAndLoad(id, std::move(entry));
}

absl::StatusOr<std::shared_ptr<Session>> SessionRegistry::AcquireAndLoad(
    const std::string& id, std::shared_ptr<Entry> entry) {
  absl::MutexLock load_lock(&entry->load_mu);
  std::shared_ptr<Session> current;
  {
    absl::MutexLock lock(&mu_);
    auto it = sessions_.find(id);
    if (it != sessions_.end()) {
      // Another call may have loaded it meanwhile.
      if (std::shared_ptr<Session> ready = Ready(it->second)) return ready;
      current = it->second.session;
    }
  }
  const Clock::time_point asked = Clock::now();
  absl::StatusOr<int64_t> fence = store_->AcquireLease(id);
  if (!fence.ok()) {
    if (absl::IsNotFound(fence.status())) {
      absl::MutexLock lock(&mu_);
      auto it = sessions_.find(id);
      if (it != sessions_.end()) {
        if (it->second.session != nullptr) it->second.session->MarkStale();
        sessions_.erase(it);
      }
      return absl::NotFoundError(absl::StrCat("session ", SessionName(id), " not found"));
    }
    return fence.status();
  }
  if (current != nullptr && !current->stale() && current->fence() == *fence) {
    // Still ours under the same fence: nobody else wrote it meanwhile.
    absl::MutexLock lock(&mu_);
    Loaded& loaded = sessions_[id];
    loaded.entry = entry;
    loaded.session = current;
    loaded.valid_until = TrustUntil(asked);
    return current;
  }
  if (current != nullptr) current->MarkStale();
  absl::StatusOr<std::shared_ptr<Session>> session = Restore(id, *fence);
  if (!session.ok()) return session.status();  // the lease stays: the next call retries
  const int64_t bytes = (*session)->EstimatedBytes((*session)->Snapshot().sample_count);
  if (absl::Status s = Reserve(bytes, absl::StrCat("loading ", SessionName(id)));
      !s.ok()) {
    store_->ReleaseLease(id, *fence).IgnoreError();
    return s;
  }
  (*session)->AttachMetrics(options_.metrics);
  (*session)->AttachMemoryBudget(options_.budget, options_.budget != nullptr ? bytes : 0);
  Log(LogLevel::kInfo,
      absl::StrCat("took ", (*session)->name(), " (fence ", *fence, ") with ",
                   (*session)->Snapshot().sample_count, " samples"));
  absl::MutexLock lock(&mu_);
  Loaded& loaded = sessions_[id];
  loaded.entry = entry;
  loaded.session = *session;
  loaded.valid_until = TrustUntil(asked);
  return *session;
}

absl::Status SessionRegistry::Release(const std::string& id,
                                      const std::shared_ptr<Session>& session,
                                      std::chrono::nanoseconds idle) {
  std::shared_ptr<Entry> entry;
  {
    absl::MutexLock lock(&mu_);
    auto it = sessions_.find(id);
    if (it == sessions_.end() || it->second.session != session) return absl::OkStatus();
    entry = it->second.entry;
  }
  // A load of this id in progress wins: try again at the next renewal.
  if (!entry->load_mu.TryLock()) return absl::OkStatus();
  bool dropped = false;
  {
    absl::MutexLock lock(&mu_);
    auto it = sessions_.find(id);
    if (it != sessions_.end() && it->second.session == session &&
        (idle.count() < 0 || session->IdleFor(idle))) {
      session->MarkStale();
      it->second.session = nullptr;
      dropped = true;
    }
  }
  absl::Status released;
  if (dropped) {
    released = store_->ReleaseLease(id, session->fence());
    if (!released.ok()) {
      Log(LogLevel::kWarning,
          absl::StrCat("releasing ", session->name(),
                       " failed (its lease will expire): ", released.message()));
    } else {
      Log(LogLevel::kInfo, absl::StrCat("released ", session->name()));
    }
  }
  entry->load_mu.Unlock();
  return released;
}

void SessionRegistry::RenewLoop() {
  const absl::Duration period = absl::FromChrono(options_.lease_ttl / 3);
  while (!stop_.WaitForNotificationWithTimeout(period)) RenewOnce();
}

void SessionRegistry::RenewOnce() {
  std::vector<store::HeldLease> held;
  std::map<std::string, std::shared_ptr<Session>> by_id;
  {
    absl::MutexLock lock(&mu_);
    for (const auto& [id, loaded] : sessions_) {
      if (loaded.session == nullptr || loaded.session->stale()) continue;
      held.push_back({id, loaded.session->fence()});
      by_id[id] = loaded.session;
    }
  }
  if (held.empty()) return;
  const Clock::time_point asked = Clock::now();
  absl::StatusOr<store::LeaseRenewal> renewal = store_->RenewLeases(held);
  if (!renewal.ok()) {
    // The leases lapse here unless a later renewal gets through in time.
    Log(LogLevel::kWarning, absl::StrCat("renewing ", held.size(),
                                         " leases failed: ", renewal.status().message()));
    return;
  }
  {
    absl::MutexLock lock(&mu_);
    for (const store::HeldLease& lease : held) {
      auto it = sessions_.find(lease.session_id);
      if (it != sessions_.end() && it->second.session == by_id[lease.session_id]) {
        it->second.valid_until = TrustUntil(asked);
      }
    }
    for (const std::string& id : renewal->lost) {
      auto it = sessions_.find(id);
      if (it == sessions_.end() || it->second.session != by_id[id]) continue;
      it->second.session->MarkStale();
      it->second.session = nullptr;
      Log(LogLevel::kInfo, absl::StrCat("lost the lease of ", SessionName(id),
                                        " (taken over or deleted elsewhere)"));
    }
  }
  for (const std::string& id : renewal->wanted) {
    Release(id, by_id[id], options_.handoff_idle).IgnoreError();  // logged
  }
  if (options_.idle_release.count() > 0) {
    for (const auto& [id, session] : by_id) {
      if (session->IdleFor(options_.idle_release))
        Release(id, session, options_.idle_release).IgnoreError();  // logged
    }
  }
}

absl::StatusOr<std::shared_ptr<Session>> SessionRegistry::ServedHere(
    const std::string& id) {
  if (!shared_) return Get(id);
  absl::MutexLock lock(&mu_);
  auto it = sessions_.find(id);
  if (it != sessions_.end()) {
    if (std::shared_ptr<Session> ready = Ready(it->second)) return ready;
  }
  return std::shared_ptr<Session>();
}

absl::StatusOr<SessionDescription> SessionRegistry::Describe(const std::string& id) {
  absl::StatusOr<std::shared_ptr<Session>> served = ServedHere(id);
  if (!served.ok()) return served.status();
  if (*served != nullptr) return (*served)->Describe();
  absl::StatusOr<store::SessionListing> listing = store_->ListSession(id);
  if (!listing.ok()) return listing.status();
  return Session::DescribeStored(*listing, *options_.format);
}

absl::StatusOr<LearningHistory> SessionRegistry::History(const std::string& id) {
  absl::StatusOr<std::shared_ptr<Session>> served = ServedHere(id);
  if (!served.ok()) return served.status();
  if (*served != nullptr) return (*served)->History();
  if (absl::StatusOr<store::SessionListing> listing = store_->ListSession(id);
      !listing.ok()) {
    return listing.status();
  }
  return LearningHistory();
}

absl::Status SessionRegistry::Delete(const std::string& id) {
  absl::StatusOr<std::shared_ptr<Session>> session = Get(id);
  if (!session.ok()) return session.status();
  // Without the registry lock: a session may be busy planning for a while.
  if (absl::Status s = (*session)->Delete(); !s.ok()) return s;
  {
    absl::MutexLock lock(&mu_);
    auto it = sessions_.find(id);
    if (it != sessions_.end() && it->second.session == *session) sessions_.erase(it);
  }
  session->reset();  // the model goes with the last reference (a busy call may hold one)
  ReturnFreedMemory();
  return absl::OkStatus();
}

absl::StatusOr<SessionRegistry::Page> SessionRegistry::List(int32_t page_size,
                                                            const std::string& page_token,
                                                            const LabelMatcher& matches) {
  if (page_size < 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("page_size: must be >= 0 (0 for the default ", kDefaultPageSize,
                     "), got ", page_size));
  }
  if (page_size == 0) page_size = kDefaultPageSize;
  if (page_size > kMaxPageSize) page_size = kMaxPageSize;
  std::string after;
  if (!page_token.empty()) {
    absl::StatusOr<std::string> decoded = DecodeToken(page_token);
    if (!decoded.ok()) return decoded.status();
    after = *std::move(decoded);
  }
  Page page;
  bool more = false;  // sessions beyond the last one looked at
  while (!more) {
    absl::StatusOr<std::vector<store::SessionListing>> batch =
        store_->ListSessions(after, kStoreBatch);
    if (!batch.ok()) return batch.status();
    if (batch->empty()) break;
    for (const store::SessionListing& listing : *batch) {
      if (static_cast<int32_t>(page.sessions.size()) == page_size) {
        more = true;
        break;
      }
      after = listing.record.id;
      if (matches && !matches(listing.record.labels)) continue;
      std::shared_ptr<Session> live;
      {
        absl::MutexLock lock(&mu_);
        auto it = sessions_.find(listing.record.id);
        if (it != sessions_.end() && it->second.session != nullptr &&
            !it->second.session->stale()) {
          live = it->second.session;
        }
      }
      page.sessions.push_back(live != nullptr
                                  ? live->Describe()
                                  : Session::DescribeStored(listing, *options_.format));
    }
    if (!more && static_cast<int32_t>(page.sessions.size()) == page_size) {
      absl::StatusOr<std::vector<store::SessionListing>> next =
          store_->ListSessions(after, 1);
      if (!next.ok()) return next.status();
      more = !next->empty();
      break;
    }
  }
  if (more && !page.sessions.empty()) {
    page.next_page_token = EncodeToken(page.sessions.back().id);
  }
  return page;
}

int64_t SessionRegistry::size() const {
  absl::MutexLock lock(&mu_);
  int64_t n = 0;
  for (const auto& [id, loaded] : sessions_) n += loaded.session != nullptr;
  return n;
}

int64_t SessionRegistry::loaded_samples() const {
  std::vector<std::shared_ptr<Session>> loaded;
  {
    absl::MutexLock lock(&mu_);
    for (const auto& [id, l] : sessions_) {
      if (l.session != nullptr) loaded.push_back(l.session);
    }
  }
  int64_t total = 0;
  for (const auto& session : loaded) total += session->Snapshot().sample_count;
  return total;
}

}  // namespace excite::session
