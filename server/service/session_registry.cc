#include "server/service/session_registry.h"

#include <algorithm>
#include <utility>

#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/time/clock.h"
#include "server/service/config_validation.h"
#include "server/service/field_violation.h"
#include "server/service/logging.h"
#include "server/service/resource_name.h"

namespace excite::service {
namespace {

constexpr int32_t kDefaultPageSize = 50;
constexpr int32_t kMaxPageSize = 1000;
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

}  // namespace

SessionRegistry::SessionRegistry(store::SessionStore* store, int64_t max_sessions,
                                 Metrics* metrics, MemoryBudget* budget)
    : store_(store), max_sessions_(max_sessions), metrics_(metrics), budget_(budget) {}

absl::StatusOr<std::unique_ptr<SessionRegistry>> SessionRegistry::Load(
    store::SessionStore* store, int64_t max_sessions, Metrics* metrics,
    MemoryBudget* budget) {
  std::unique_ptr<SessionRegistry> registry(
      new SessionRegistry(store, max_sessions, metrics, budget));
  absl::StatusOr<std::vector<store::SessionRecord>> records = store->LoadSessions();
  if (!records.ok()) return records.status();
  absl::MutexLock lock(&registry->mu_);
  for (const store::SessionRecord& record : *records) {
    // Rows that cannot be read set their session aside, not the server.
    std::vector<int64_t> unreadable;
    absl::StatusOr<std::vector<store::SampleRecord>> samples =
        store->LoadSamples(record.id, &unreadable);
    if (!samples.ok()) return samples.status();
    absl::Status damage;
    if (!unreadable.empty()) {
      damage = absl::DataLossError(absl::StrCat(
          unreadable.size(), " stored samples cannot be read (sequence ",
          absl::StrJoin(unreadable.begin(),
                        unreadable.begin() + std::min<size_t>(unreadable.size(), 5),
                        ", "),
          unreadable.size() > 5 ? ", ..." : "", ")"));
    }
    absl::StatusOr<std::shared_ptr<Session>> session =
        Session::Restore(record, *samples, store, std::move(damage));
    if (!session.ok()) return session.status();
    Log(LogLevel::kInfo, absl::StrCat("loaded ", (*session)->name(), " with ",
                                      samples->size(), " samples"));
    (*session)->AttachMetrics(metrics);
    if (budget != nullptr) {
      // Stored already: counted even beyond the budget, which then refuses growth.
      const int64_t bytes =
          (*session)->EstimatedBytes(static_cast<int64_t>(samples->size()));
      budget->ForceReserve(bytes);
      (*session)->AttachMemoryBudget(budget, bytes);
    }
    registry->sessions_.emplace(record.id, *std::move(session));
  }
  return registry;
}

std::string SessionRegistry::GenerateId() {
  static constexpr char kAlphabet[] = "0123456789abcdefghijklmnopqrstuvwxyz";
  while (true) {
    std::string id = "s-";
    for (int i = 0; i < 12; ++i) {
      id.push_back(kAlphabet[absl::Uniform<size_t>(bitgen_, 0, sizeof(kAlphabet) - 1)]);
    }
    if (sessions_.find(id) == sessions_.end()) return id;
  }
}

absl::StatusOr<std::shared_ptr<Session>> SessionRegistry::Create(
    const std::string& session_id, const v1::SessionConfig& config,
    const std::string& display_name,
    const google::protobuf::Map<std::string, std::string>& labels) {
  absl::StatusOr<v1::SessionConfig> validated = ValidatedSessionConfig(config, "config");
  Violations problems;
  problems.Add(CheckOptionalSessionId(session_id, "session_id"));
  problems.Add(validated.status());
  problems.Add(ValidateDisplayNameAndLabels(display_name, labels));
  if (absl::Status s = problems.Result(); !s.ok()) return s;
  Session::Metadata metadata{display_name, Labels(labels.begin(), labels.end()),
                             absl::ToUnixMillis(absl::Now())};

  absl::MutexLock lock(&mu_);
  absl::StatusOr<std::string> id = NewSessionId(session_id);
  if (!id.ok()) return id.status();
  absl::StatusOr<std::shared_ptr<Session>> session =
      Session::Create(*id, *validated, metadata, store_);
  if (!session.ok()) return session.status();
  const int64_t bytes = (*session)->EstimatedBytes(0);
  if (absl::Status s = Reserve(bytes, absl::StrCat("a new session ", SessionName(*id)));
      !s.ok()) {
    return s;
  }
  store::SessionRecord record;
  record.id = *id;
  record.config = validated->SerializeAsString();
  record.created_unix_ms = metadata.created_unix_ms;
  record.display_name = metadata.display_name;
  record.labels = metadata.labels;
  if (absl::Status s = store_->CreateSession(record); !s.ok()) {
    if (budget_ != nullptr) budget_->Release(bytes);
    return s;
  }
  (*session)->AttachMetrics(metrics_);
  (*session)->AttachMemoryBudget(budget_, bytes);
  sessions_.emplace(*id, *session);
  return session;
}

absl::StatusOr<std::string> SessionRegistry::NewSessionId(const std::string& session_id) {
  std::string id = session_id.empty() ? GenerateId() : session_id;
  if (sessions_.count(id) > 0) {
    return absl::AlreadyExistsError(
        absl::StrCat("session ", SessionName(id), " already exists"));
  }
  if (static_cast<int64_t>(sessions_.size()) >= max_sessions_) {
    return absl::ResourceExhaustedError(absl::StrCat(
        "the server holds ", sessions_.size(), " sessions, its cap: delete one first"));
  }
  return id;
}

absl::StatusOr<std::shared_ptr<Session>> SessionRegistry::Import(
    const std::string& session_id, store::SessionRecord record,
    const std::vector<store::SampleRecord>& samples) {
  absl::MutexLock lock(&mu_);
  absl::StatusOr<std::string> id = NewSessionId(session_id);
  if (!id.ok()) return id.status();
  record.id = *id;
  record.model_version = 0;
  // Built in memory first (as after a restart: the hyperparameters seed the first
  // refit), stored second: a failure of either leaves nothing behind.
  absl::StatusOr<std::shared_ptr<Session>> session =
      Session::Restore(record, samples, store_);
  if (!session.ok()) return session.status();
  const int64_t bytes = (*session)->EstimatedBytes(static_cast<int64_t>(samples.size()));
  if (absl::Status s = Reserve(bytes, absl::StrCat("importing ", SessionName(*id),
                                                   " with ", samples.size(), " samples"));
      !s.ok()) {
    return s;
  }
  if (absl::Status s = store_->ImportSession(record, samples); !s.ok()) {
    if (budget_ != nullptr) budget_->Release(bytes);
    return s;
  }
  (*session)->AttachMetrics(metrics_);
  (*session)->AttachMemoryBudget(budget_, bytes);
  sessions_.emplace(*id, *session);
  return session;
}

absl::Status SessionRegistry::Reserve(int64_t bytes, absl::string_view what) {
  return budget_ != nullptr ? budget_->Reserve(bytes, what) : absl::OkStatus();
}

absl::StatusOr<std::shared_ptr<Session>> SessionRegistry::Get(
    const std::string& id) const {
  absl::MutexLock lock(&mu_);
  auto it = sessions_.find(id);
  if (it == sessions_.end()) {
    return absl::NotFoundError(absl::StrCat("session ", SessionName(id), " not found"));
  }
  return it->second;
}

absl::Status SessionRegistry::Delete(const std::string& id) {
  absl::StatusOr<std::shared_ptr<Session>> session = Get(id);
  if (!session.ok()) return session.status();
  // Without the registry lock: a session may be busy planning for a while.
  if (absl::Status s = (*session)->Delete(); !s.ok()) return s;
  absl::MutexLock lock(&mu_);
  auto it = sessions_.find(id);
  if (it != sessions_.end() && it->second == *session) sessions_.erase(it);
  return absl::OkStatus();
}

absl::StatusOr<SessionRegistry::Page> SessionRegistry::List(
    int32_t page_size, const std::string& page_token, const LabelFilter& filter) const {
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
  absl::MutexLock lock(&mu_);
  auto it = after.empty() ? sessions_.begin() : sessions_.upper_bound(after);
  for (; it != sessions_.end() && static_cast<int32_t>(page.sessions.size()) < page_size;
       ++it) {
    if (filter.Matches(it->second->labels())) page.sessions.push_back(it->second);
  }
  if (it != sessions_.end() && !page.sessions.empty()) {
    page.next_page_token = EncodeToken(page.sessions.back()->id());
  }
  return page;
}

int64_t SessionRegistry::size() const {
  absl::MutexLock lock(&mu_);
  return static_cast<int64_t>(sessions_.size());
}

}  // namespace excite::service
