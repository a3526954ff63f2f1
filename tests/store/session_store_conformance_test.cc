// What every store::SessionStore promises, run against each backend: SQLite in a
// temporary directory and PostgreSQL on a real server (tests/support), a fresh
// database per test. Backend-specific behaviour (SQLite's migration and file
// lock, PostgreSQL's leases between replicas) has its own tests.

#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "server/store/postgres_store.h"
#include "server/store/sqlite_store.h"
#include "tests/store/store_test_records.h"
#include "tests/support/postgres_environment.h"
#include "tests/support/temp_dir.h"

namespace excite::store {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

using ::excite::store::testing::Sample;
using ::excite::store::testing::Session;

// Opens the backend's store; Reopen() closes it and opens it again on the same
// data (durability).
class Backend {
 public:
  virtual ~Backend() = default;
  virtual absl::StatusOr<std::unique_ptr<SessionStore>> Open() = 0;
};

class SqliteBackend : public Backend {
 public:
  absl::StatusOr<std::unique_ptr<SessionStore>> Open() override {
    absl::StatusOr<std::unique_ptr<SqliteStore>> store = SqliteStore::Open(dir_.path());
    if (!store.ok()) return store.status();
    return std::unique_ptr<SessionStore>(*std::move(store));
  }

 private:
  excite::testing::TempDir dir_;
};

const excite::testing::PostgresEnvironment* const kPostgres =
    excite::testing::PostgresEnvironment::Register();

class PostgresBackend : public Backend {
 public:
  PostgresBackend()
      : dbname_(excite::testing::PostgresEnvironment::NewDatabase("conformance")) {}
  absl::StatusOr<std::unique_ptr<SessionStore>> Open() override {
    excite::testing::PostgresServer* server =
        excite::testing::PostgresEnvironment::server();
    if (server == nullptr || dbname_.empty()) {
      return absl::FailedPreconditionError("no PostgreSQL database");
    }
    PostgresStoreOptions options;
    options.url = server->url(dbname_);
    options.password = server->password();
    options.owner = "conformance";
    absl::StatusOr<std::unique_ptr<PostgresStore>> store = PostgresStore::Open(options);
    if (!store.ok()) return store.status();
    return std::unique_ptr<SessionStore>(*std::move(store));
  }

 private:
  std::string dbname_;
};

class SessionStoreTest : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    if (GetParam() == "sqlite") {
      backend_ = std::make_unique<SqliteBackend>();
    } else {
      backend_ = std::make_unique<PostgresBackend>();
    }
    Reopen();
  }

  void Reopen() {
    store_.reset();
    absl::StatusOr<std::unique_ptr<SessionStore>> store = backend_->Open();
    ASSERT_TRUE(store.ok()) << store.status();
    store_ = *std::move(store);
  }

  // The fence this store's writes of `id` carry (the lease taken first).
  int64_t Lease(const std::string& id) {
    absl::StatusOr<int64_t> fence = store_->AcquireLease(id);
    EXPECT_TRUE(fence.ok()) << fence.status();
    return fence.ok() ? *fence : -1;
  }

  absl::StatusOr<InsertResult> Insert(const std::string& id,
                                      const std::vector<SampleRecord>& batch) {
    return store_->InsertSamples(id, Lease(id), batch);
  }

  std::vector<SessionListing> ListAll() {
    absl::StatusOr<std::vector<SessionListing>> all = store_->ListSessions("", 1000);
    EXPECT_TRUE(all.ok()) << all.status();
    return all.ok() ? *all : std::vector<SessionListing>();
  }

  std::unique_ptr<Backend> backend_;
  std::unique_ptr<SessionStore> store_;
};

TEST_P(SessionStoreTest, DataSurvivesReopen) {
  ASSERT_TRUE(store_->CreateSession(Session("b-session")).ok());
  ASSERT_TRUE(store_->CreateSession(Session("a-session")).ok());
  auto inserted = Insert("a-session", {Sample(0), Sample(1), Sample(2)});
  ASSERT_TRUE(inserted.ok()) << inserted.status();
  ASSERT_TRUE(store_->SaveModelState("a-session", Lease("a-session"), "hyper", 7).ok());
  Reopen();
  const std::vector<SessionListing> sessions = ListAll();
  ASSERT_EQ(sessions.size(), 2u);
  EXPECT_EQ(sessions[0].record.id, "a-session");  // id order
  EXPECT_EQ(sessions[1].record.id, "b-session");
  EXPECT_EQ(sessions[0].record.config, Session("a").config);
  EXPECT_EQ(sessions[0].record.created_unix_ms, 1700000000123);
  EXPECT_EQ(sessions[0].record.hyperparameters, "hyper");
  EXPECT_EQ(sessions[0].record.model_version, 7);
  EXPECT_EQ(sessions[0].sample_count, 3);
  EXPECT_EQ(sessions[0].last_sequence, 2);
  EXPECT_EQ(sessions[1].record.hyperparameters, "");
  EXPECT_EQ(sessions[1].sample_count, 0);
  EXPECT_EQ(sessions[1].last_sequence, -1);

  auto samples = store_->LoadSamples("a-session", nullptr);
  ASSERT_TRUE(samples.ok()) << samples.status();
  ASSERT_EQ(samples->size(), 3u);
  for (int i = 0; i < 3; ++i) {
    const SampleRecord expected = Sample(i);
    EXPECT_EQ((*samples)[i].sequence, i);
    EXPECT_EQ((*samples)[i].state, expected.state);  // bit-exact round trip
    EXPECT_EQ((*samples)[i].input, expected.input);
    EXPECT_EQ((*samples)[i].next_state, expected.next_state);
    EXPECT_EQ((*samples)[i].timestamp_s, expected.timestamp_s);
  }
  auto none = store_->LoadSamples("b-session", nullptr);
  ASSERT_TRUE(none.ok());
  EXPECT_TRUE(none->empty());
}

TEST_P(SessionStoreTest, ExtremeFiniteValuesRoundTripBitExactly) {
  ASSERT_TRUE(store_->CreateSession(Session("s")).ok());
  SampleRecord sample = Sample(3);
  sample.state = {std::numeric_limits<double>::denorm_min(), -0.0,
                  std::numeric_limits<double>::max(), 1e30, -1e-30};
  sample.input = {std::nextafter(1.0, 2.0)};
  sample.next_state = {1.0 / 3.0, -std::numeric_limits<double>::min(), 0.1, 2.5, 7e-310};
  sample.timestamp_s = 1700000000.123456789;
  ASSERT_TRUE(Insert("s", {sample}).ok());
  Reopen();
  auto samples = store_->LoadSamples("s", nullptr);
  ASSERT_TRUE(samples.ok()) << samples.status();
  ASSERT_EQ(samples->size(), 1u);
  const SampleRecord& got = (*samples)[0];
  ASSERT_EQ(got.state.size(), sample.state.size());
  for (size_t i = 0; i < sample.state.size(); ++i) {
    EXPECT_EQ(std::signbit(got.state[i]), std::signbit(sample.state[i]));
    EXPECT_EQ(got.state[i], sample.state[i]);
  }
  EXPECT_EQ(got.input, sample.input);
  EXPECT_EQ(got.next_state, sample.next_state);
  EXPECT_EQ(got.timestamp_s, sample.timestamp_s);
}

TEST_P(SessionStoreTest, InsertIsIdempotentPerSequence) {
  ASSERT_TRUE(store_->CreateSession(Session("s")).ok());
  auto first = Insert("s", {Sample(0), Sample(1)});
  ASSERT_TRUE(first.ok()) << first.status();
  EXPECT_THAT(first->stored, ElementsAre(true, true));
  EXPECT_EQ(first->stored_count, 2);
  EXPECT_EQ(first->duplicate_count, 0);

  // A retry overlapping the first batch, with a repeat inside the batch too.
  SampleRecord changed = Sample(1);
  changed.state = {99.0, 99.0};
  SampleRecord changed_two = Sample(2);
  changed_two.state = {42.0, 42.0};
  auto second = Insert("s", {changed, Sample(2), changed_two});
  ASSERT_TRUE(second.ok()) << second.status();
  EXPECT_THAT(second->stored, ElementsAre(false, true, false));
  EXPECT_EQ(second->stored_count, 1);
  EXPECT_EQ(second->duplicate_count, 2);

  auto samples = store_->LoadSamples("s", nullptr);
  ASSERT_TRUE(samples.ok());
  ASSERT_EQ(samples->size(), 3u);
  EXPECT_EQ((*samples)[1].state, Sample(1).state);  // the first write wins
  EXPECT_EQ((*samples)[2].state, Sample(2).state);  // the batch's first one
}

TEST_P(SessionStoreTest, EmptyBatchStoresNothing) {
  ASSERT_TRUE(store_->CreateSession(Session("s")).ok());
  auto result = Insert("s", {});
  ASSERT_TRUE(result.ok()) << result.status();
  EXPECT_EQ(result->stored_count, 0);
  EXPECT_TRUE(result->stored.empty());
}

TEST_P(SessionStoreTest, SameSequenceInDifferentSessionsIsNotADuplicate) {
  ASSERT_TRUE(store_->CreateSession(Session("a")).ok());
  ASSERT_TRUE(store_->CreateSession(Session("b")).ok());
  ASSERT_EQ(Insert("a", {Sample(5)})->stored_count, 1);
  ASSERT_EQ(Insert("b", {Sample(5)})->stored_count, 1);
}

TEST_P(SessionStoreTest, UnknownSessionIsNotFoundAndWritesNothing) {
  EXPECT_TRUE(absl::IsNotFound(store_->AcquireLease("ghost").status()));
  EXPECT_TRUE(absl::IsNotFound(store_->InsertSamples("ghost", 0, {Sample(0)}).status()));
  EXPECT_TRUE(absl::IsNotFound(store_->SaveModelState("ghost", 0, "h", 1)));
  EXPECT_TRUE(absl::IsNotFound(store_->DeleteSession("ghost", 0)));
  EXPECT_TRUE(absl::IsNotFound(store_->LoadSession("ghost").status()));
  ASSERT_TRUE(store_->CreateSession(Session("ghost")).ok());
  EXPECT_TRUE(store_->LoadSamples("ghost", nullptr)->empty());
}

TEST_P(SessionStoreTest, CreateTwiceIsAlreadyExists) {
  ASSERT_TRUE(store_->CreateSession(Session("s")).ok());
  absl::Status status = store_->CreateSession(Session("s"));
  EXPECT_EQ(status.code(), absl::StatusCode::kAlreadyExists);
  EXPECT_THAT(status.message(), HasSubstr("sessions/s"));
}

TEST_P(SessionStoreTest, ImportStoresSessionAndSamplesTogether) {
  SessionRecord record = Session("imported");
  record.hyperparameters = "hyper";
  record.model_version = 3;
  ASSERT_TRUE(store_->ImportSession(record, {Sample(4), Sample(1), Sample(2)}).ok());
  Reopen();  // durable
  auto loaded = store_->LoadSession("imported");
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  EXPECT_EQ(loaded->config, Session("x").config);
  EXPECT_EQ(loaded->created_unix_ms, 1700000000123);
  EXPECT_EQ(loaded->hyperparameters, "hyper");
  EXPECT_EQ(loaded->model_version, 3);
  auto samples = store_->LoadSamples("imported", nullptr);
  ASSERT_TRUE(samples.ok()) << samples.status();
  ASSERT_EQ(samples->size(), 3u);
  EXPECT_EQ((*samples)[0].sequence, 1);
  EXPECT_EQ((*samples)[2].state, Sample(4).state);
}

TEST_P(SessionStoreTest, LargeImportIsStoredWhole) {
  std::vector<SampleRecord> samples;
  for (int i = 0; i < 5000; ++i) samples.push_back(Sample(i));
  ASSERT_TRUE(store_->ImportSession(Session("big"), samples).ok());
  auto loaded = store_->LoadSamples("big", nullptr);
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  ASSERT_EQ(loaded->size(), 5000u);
  EXPECT_EQ(loaded->back().sequence, 4999);
  EXPECT_EQ(loaded->back().input, Sample(4999).input);
}

// All or nothing: a failure half-way (a duplicate sequence number, a taken id)
// leaves neither the session nor any of its samples.
TEST_P(SessionStoreTest, FailedImportStoresNothing) {
  const absl::Status duplicate =
      store_->ImportSession(Session("half"), {Sample(0), Sample(1), Sample(0)});
  EXPECT_FALSE(duplicate.ok());
  EXPECT_THAT(std::string(duplicate.message()), HasSubstr("half"));
  EXPECT_TRUE(ListAll().empty());
  auto samples = store_->LoadSamples("half", nullptr);
  ASSERT_TRUE(samples.ok()) << samples.status();
  EXPECT_TRUE(samples->empty());

  ASSERT_TRUE(store_->CreateSession(Session("taken")).ok());
  ASSERT_TRUE(Insert("taken", {Sample(7)}).ok());
  const absl::Status taken = store_->ImportSession(Session("taken"), {Sample(8)});
  EXPECT_TRUE(absl::IsAlreadyExists(taken)) << taken;
  samples = store_->LoadSamples("taken", nullptr);
  ASSERT_TRUE(samples.ok()) << samples.status();
  ASSERT_EQ(samples->size(), 1u);
  EXPECT_EQ((*samples)[0].sequence, 7);
  // The store is usable afterwards (no transaction left open).
  EXPECT_TRUE(store_->ImportSession(Session("half"), {Sample(0), Sample(1)}).ok());
}

TEST_P(SessionStoreTest, DeleteRemovesSessionLabelsAndSamples) {
  SessionRecord labelled = Session("s");
  labelled.labels = {{"k", "v"}};
  ASSERT_TRUE(store_->CreateSession(labelled).ok());
  ASSERT_TRUE(store_->CreateSession(Session("keep")).ok());
  ASSERT_TRUE(Insert("s", {Sample(0), Sample(1)}).ok());
  ASSERT_TRUE(Insert("keep", {Sample(0)}).ok());
  const int64_t fence = Lease("s");
  ASSERT_TRUE(store_->DeleteSession("s", fence).ok());
  EXPECT_EQ(store_->DeleteSession("s", fence).code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(store_->SaveModelState("s", fence, "h", 1).code(),
            absl::StatusCode::kNotFound);
  Reopen();
  const std::vector<SessionListing> sessions = ListAll();
  ASSERT_EQ(sessions.size(), 1u);
  EXPECT_EQ(sessions[0].record.id, "keep");
  EXPECT_TRUE(store_->LoadSamples("s", nullptr)->empty());
  EXPECT_EQ(store_->LoadSamples("keep", nullptr)->size(), 1u);
  // The id can be used again and starts empty.
  ASSERT_TRUE(store_->CreateSession(Session("s")).ok());
  EXPECT_TRUE(store_->LoadSamples("s", nullptr)->empty());
  EXPECT_TRUE(store_->LoadSession("s")->labels.empty());
}

TEST_P(SessionStoreTest, DisplayNamesAndLabelsRoundTrip) {
  SessionRecord labelled = Session("labelled");
  labelled.display_name = "Pendulum, lab B12 \xc3\xa9 \"quoted\" {braces},\\";
  labelled.labels = {
      {"plant", "pendulum"}, {"run", "7"}, {"empty", ""}, {"odd", "a,b {c} \"d\" \\e"}};
  ASSERT_TRUE(store_->CreateSession(labelled).ok());
  ASSERT_TRUE(store_->CreateSession(Session("plain")).ok());
  SessionRecord imported = Session("imported");
  imported.labels = {{"plant", "unicycle"}};
  ASSERT_TRUE(store_->ImportSession(imported, {Sample(0)}).ok());
  Reopen();
  auto loaded = store_->LoadSession("labelled");
  ASSERT_TRUE(loaded.ok());
  EXPECT_EQ(loaded->display_name, labelled.display_name);
  EXPECT_EQ(loaded->labels, labelled.labels);
  const std::vector<SessionListing> sessions = ListAll();
  ASSERT_EQ(sessions.size(), 3u);
  EXPECT_EQ(sessions[0].record.labels.at("plant"), "unicycle");  // "imported"
  EXPECT_EQ(sessions[1].record.labels, labelled.labels);
  EXPECT_TRUE(sessions[2].record.labels.empty());  // "plain"
  EXPECT_EQ(sessions[2].record.display_name, "");
}

TEST_P(SessionStoreTest, ListsPagesInIdOrderAndCounts) {
  for (const char* id : {"c", "a-2", "b", "a-10", "a"}) {
    ASSERT_TRUE(store_->CreateSession(Session(id)).ok());
  }
  ASSERT_TRUE(Insert("b", {Sample(4), Sample(9)}).ok());
  absl::StatusOr<int64_t> count = store_->CountSessions();
  ASSERT_TRUE(count.ok()) << count.status();
  EXPECT_EQ(*count, 5);
  // Byte order, as SQLite and std::map order ids ("a-10" < "a-2").
  auto first = store_->ListSessions("", 2);
  ASSERT_TRUE(first.ok()) << first.status();
  ASSERT_EQ(first->size(), 2u);
  EXPECT_EQ((*first)[0].record.id, "a");
  EXPECT_EQ((*first)[1].record.id, "a-10");
  auto rest = store_->ListSessions("a-10", 10);
  ASSERT_TRUE(rest.ok()) << rest.status();
  ASSERT_EQ(rest->size(), 3u);
  EXPECT_EQ((*rest)[0].record.id, "a-2");
  EXPECT_EQ((*rest)[1].record.id, "b");
  EXPECT_EQ((*rest)[1].sample_count, 2);
  EXPECT_EQ((*rest)[1].last_sequence, 9);
  EXPECT_EQ((*rest)[2].record.id, "c");
  EXPECT_TRUE(store_->ListSessions("c", 10)->empty());
  absl::StatusOr<SessionListing> one = store_->ListSession("b");
  ASSERT_TRUE(one.ok()) << one.status();
  EXPECT_EQ(one->record.id, "b");
  EXPECT_EQ(one->record.config, Session("b").config);
  EXPECT_EQ(one->sample_count, 2);
  EXPECT_EQ(one->last_sequence, 9);
  EXPECT_EQ(store_->ListSession("a")->sample_count, 0);
  EXPECT_TRUE(absl::IsNotFound(store_->ListSession("zz").status()));
}

TEST_P(SessionStoreTest, LeasesOfOneReplicaAreKept) {
  ASSERT_TRUE(store_->CreateSession(Session("s")).ok());
  const int64_t fence = Lease("s");
  EXPECT_EQ(Lease("s"), fence);  // taken again by its owner: the same fence
  auto renewal = store_->RenewLeases({{"s", fence}});
  ASSERT_TRUE(renewal.ok()) << renewal.status();
  EXPECT_TRUE(renewal->lost.empty());
  EXPECT_TRUE(renewal->wanted.empty());
  EXPECT_TRUE(store_->ReleaseLease("s", fence).ok());
  EXPECT_TRUE(store_->InsertSamples("s", Lease("s"), {Sample(1)}).ok());
}

INSTANTIATE_TEST_SUITE_P(Backends, SessionStoreTest,
                         ::testing::Values("sqlite", "postgresql"),
                         [](const ::testing::TestParamInfo<std::string>& backend) {
                           return backend.param;
                         });

}  // namespace
}  // namespace excite::store
