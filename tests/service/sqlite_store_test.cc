#include "server/store/sqlite_store.h"

#include <sqlite3.h>

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/service/temp_dir.h"

namespace excite::store {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

SampleRecord Sample(int64_t sequence) {
  SampleRecord s;
  s.sequence = sequence;
  s.state = {0.1 * sequence, -1.5};
  s.input = {2.0 + sequence};
  s.next_state = {0.25, 1e-300};
  s.timestamp_s = 1700000000.5 + sequence;
  return s;
}

SessionRecord Session(const std::string& id) {
  SessionRecord r;
  r.id = id;
  r.config = std::string("\x08\x02\x10\x01\0bytes", 10);  // arbitrary bytes with a NUL
  r.created_unix_ms = 1700000000123;
  return r;
}

TEST(SqliteStoreTest, OpenCreatesDirectoryAndDatabase) {
  excite::testing::TempDir tmp;
  const std::string dir = tmp.path() + "/nested/data";
  auto store = SqliteStore::Open(dir);
  ASSERT_TRUE(store.ok()) << store.status();
  EXPECT_TRUE(std::filesystem::exists(dir + "/excite.db"));
  EXPECT_EQ((*store)->path(), dir + "/excite.db");
}

TEST(SqliteStoreTest, DataSurvivesReopen) {
  excite::testing::TempDir tmp;
  {
    auto store = SqliteStore::Open(tmp.path());
    ASSERT_TRUE(store.ok()) << store.status();
    ASSERT_TRUE((*store)->CreateSession(Session("b-session")).ok());
    ASSERT_TRUE((*store)->CreateSession(Session("a-session")).ok());
    auto inserted =
        (*store)->InsertSamples("a-session", {Sample(0), Sample(1), Sample(2)});
    ASSERT_TRUE(inserted.ok()) << inserted.status();
    ASSERT_TRUE((*store)->SaveModelState("a-session", "hyper", 7).ok());
  }
  auto store = SqliteStore::Open(tmp.path());
  ASSERT_TRUE(store.ok()) << store.status();
  auto sessions = (*store)->LoadSessions();
  ASSERT_TRUE(sessions.ok()) << sessions.status();
  ASSERT_EQ(sessions->size(), 2u);
  EXPECT_EQ((*sessions)[0].id, "a-session");  // id order
  EXPECT_EQ((*sessions)[1].id, "b-session");
  EXPECT_EQ((*sessions)[0].config, Session("a").config);
  EXPECT_EQ((*sessions)[0].created_unix_ms, 1700000000123);
  EXPECT_EQ((*sessions)[0].hyperparameters, "hyper");
  EXPECT_EQ((*sessions)[0].model_version, 7);
  EXPECT_EQ((*sessions)[1].hyperparameters, "");

  auto samples = (*store)->LoadSamples("a-session");
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
  auto none = (*store)->LoadSamples("b-session");
  ASSERT_TRUE(none.ok());
  EXPECT_TRUE(none->empty());
}

TEST(SqliteStoreTest, InsertIsIdempotentPerSequence) {
  excite::testing::TempDir tmp;
  auto store = SqliteStore::Open(tmp.path());
  ASSERT_TRUE(store.ok());
  ASSERT_TRUE((*store)->CreateSession(Session("s")).ok());
  auto first = (*store)->InsertSamples("s", {Sample(0), Sample(1)});
  ASSERT_TRUE(first.ok());
  EXPECT_THAT(first->stored, ElementsAre(true, true));
  EXPECT_EQ(first->stored_count, 2);
  EXPECT_EQ(first->duplicate_count, 0);

  // A retry overlapping the first batch, with a repeat inside the batch too.
  SampleRecord changed = Sample(1);
  changed.state = {99.0, 99.0};
  auto second = (*store)->InsertSamples("s", {changed, Sample(2), Sample(2)});
  ASSERT_TRUE(second.ok());
  EXPECT_THAT(second->stored, ElementsAre(false, true, false));
  EXPECT_EQ(second->stored_count, 1);
  EXPECT_EQ(second->duplicate_count, 2);

  auto samples = (*store)->LoadSamples("s");
  ASSERT_TRUE(samples.ok());
  ASSERT_EQ(samples->size(), 3u);
  EXPECT_EQ((*samples)[1].state, Sample(1).state);  // the first write wins
}

TEST(SqliteStoreTest, SameSequenceInDifferentSessionsIsNotADuplicate) {
  excite::testing::TempDir tmp;
  auto store = SqliteStore::Open(tmp.path());
  ASSERT_TRUE(store.ok());
  ASSERT_TRUE((*store)->CreateSession(Session("a")).ok());
  ASSERT_TRUE((*store)->CreateSession(Session("b")).ok());
  ASSERT_EQ((*store)->InsertSamples("a", {Sample(5)})->stored_count, 1);
  ASSERT_EQ((*store)->InsertSamples("b", {Sample(5)})->stored_count, 1);
}

TEST(SqliteStoreTest, InsertIntoUnknownSessionIsNotFoundAndWritesNothing) {
  excite::testing::TempDir tmp;
  auto store = SqliteStore::Open(tmp.path());
  ASSERT_TRUE(store.ok());
  auto result = (*store)->InsertSamples("ghost", {Sample(0)});
  EXPECT_EQ(result.status().code(), absl::StatusCode::kNotFound);
  ASSERT_TRUE((*store)->CreateSession(Session("ghost")).ok());
  EXPECT_TRUE((*store)->LoadSamples("ghost")->empty());
}

TEST(SqliteStoreTest, CreateTwiceIsAlreadyExists) {
  excite::testing::TempDir tmp;
  auto store = SqliteStore::Open(tmp.path());
  ASSERT_TRUE(store.ok());
  ASSERT_TRUE((*store)->CreateSession(Session("s")).ok());
  absl::Status status = (*store)->CreateSession(Session("s"));
  EXPECT_EQ(status.code(), absl::StatusCode::kAlreadyExists);
  EXPECT_THAT(status.message(), HasSubstr("sessions/s"));
}

TEST(SqliteStoreTest, ImportStoresSessionAndSamplesTogether) {
  excite::testing::TempDir tmp;
  {
    auto store = SqliteStore::Open(tmp.path());
    ASSERT_TRUE(store.ok()) << store.status();
    SessionRecord record = Session("imported");
    record.hyperparameters = "hyper";
    record.model_version = 3;
    ASSERT_TRUE((*store)->ImportSession(record, {Sample(4), Sample(1), Sample(2)}).ok());
  }
  auto store = SqliteStore::Open(tmp.path());  // durable
  ASSERT_TRUE(store.ok()) << store.status();
  auto loaded = (*store)->LoadSession("imported");
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  EXPECT_EQ(loaded->config, Session("x").config);
  EXPECT_EQ(loaded->created_unix_ms, 1700000000123);
  EXPECT_EQ(loaded->hyperparameters, "hyper");
  EXPECT_EQ(loaded->model_version, 3);
  auto samples = (*store)->LoadSamples("imported");
  ASSERT_TRUE(samples.ok()) << samples.status();
  ASSERT_EQ(samples->size(), 3u);
  EXPECT_EQ((*samples)[0].sequence, 1);
  EXPECT_EQ((*samples)[2].state, Sample(4).state);
  EXPECT_TRUE(absl::IsNotFound((*store)->LoadSession("nope").status()));
}

// All or nothing: a failure half-way (a duplicate sequence number, a taken id)
// leaves neither the session nor any of its samples.
TEST(SqliteStoreTest, FailedImportStoresNothing) {
  excite::testing::TempDir tmp;
  auto store = SqliteStore::Open(tmp.path());
  ASSERT_TRUE(store.ok()) << store.status();
  const absl::Status duplicate =
      (*store)->ImportSession(Session("half"), {Sample(0), Sample(1), Sample(0)});
  EXPECT_FALSE(duplicate.ok());
  EXPECT_THAT(std::string(duplicate.message()), HasSubstr("sample 0 of half"));
  auto sessions = (*store)->LoadSessions();
  ASSERT_TRUE(sessions.ok()) << sessions.status();
  EXPECT_TRUE(sessions->empty());
  auto samples = (*store)->LoadSamples("half");
  ASSERT_TRUE(samples.ok()) << samples.status();
  EXPECT_TRUE(samples->empty());

  ASSERT_TRUE((*store)->CreateSession(Session("taken")).ok());
  ASSERT_TRUE((*store)->InsertSamples("taken", {Sample(7)}).ok());
  const absl::Status taken = (*store)->ImportSession(Session("taken"), {Sample(8)});
  EXPECT_TRUE(absl::IsAlreadyExists(taken)) << taken;
  samples = (*store)->LoadSamples("taken");
  ASSERT_TRUE(samples.ok()) << samples.status();
  ASSERT_EQ(samples->size(), 1u);
  EXPECT_EQ((*samples)[0].sequence, 7);
  // The store is usable afterwards (no transaction left open).
  EXPECT_TRUE((*store)->ImportSession(Session("half"), {Sample(0), Sample(1)}).ok());
}

TEST(SqliteStoreTest, DeleteRemovesSessionAndSamples) {
  excite::testing::TempDir tmp;
  {
    auto store = SqliteStore::Open(tmp.path());
    ASSERT_TRUE(store.ok());
    ASSERT_TRUE((*store)->CreateSession(Session("s")).ok());
    ASSERT_TRUE((*store)->CreateSession(Session("keep")).ok());
    ASSERT_TRUE((*store)->InsertSamples("s", {Sample(0), Sample(1)}).ok());
    ASSERT_TRUE((*store)->InsertSamples("keep", {Sample(0)}).ok());
    ASSERT_TRUE((*store)->DeleteSession("s").ok());
    EXPECT_EQ((*store)->DeleteSession("s").code(), absl::StatusCode::kNotFound);
    EXPECT_EQ((*store)->SaveModelState("s", "h", 1).code(), absl::StatusCode::kNotFound);
  }
  auto store = SqliteStore::Open(tmp.path());
  ASSERT_TRUE(store.ok());
  auto sessions = (*store)->LoadSessions();
  ASSERT_TRUE(sessions.ok());
  ASSERT_EQ(sessions->size(), 1u);
  EXPECT_EQ((*sessions)[0].id, "keep");
  EXPECT_TRUE((*store)->LoadSamples("s")->empty());
  EXPECT_EQ((*store)->LoadSamples("keep")->size(), 1u);
  // The id can be used again and starts empty.
  ASSERT_TRUE((*store)->CreateSession(Session("s")).ok());
  EXPECT_TRUE((*store)->LoadSamples("s")->empty());
}

void RunSql(const std::string& db_path, const char* sql) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(db_path.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db, sql, nullptr, nullptr, nullptr), SQLITE_OK)
      << sqlite3_errmsg(db);
  sqlite3_close(db);
}

TEST(SqliteStoreTest, DisplayNamesAndLabelsRoundTripAndGoWithTheSession) {
  excite::testing::TempDir tmp;
  {
    auto store = SqliteStore::Open(tmp.path());
    ASSERT_TRUE(store.ok());
    SessionRecord labelled = Session("labelled");
    labelled.display_name = "Pendulum, lab B12 \xc3\xa9";
    labelled.labels = {{"plant", "pendulum"}, {"run", "7"}, {"empty", ""}};
    ASSERT_TRUE((*store)->CreateSession(labelled).ok());
    ASSERT_TRUE((*store)->CreateSession(Session("plain")).ok());
    SessionRecord imported = Session("imported");
    imported.labels = {{"plant", "unicycle"}};
    ASSERT_TRUE((*store)->ImportSession(imported, {Sample(0)}).ok());
  }
  auto store = SqliteStore::Open(tmp.path());
  ASSERT_TRUE(store.ok());
  auto labelled = (*store)->LoadSession("labelled");
  ASSERT_TRUE(labelled.ok());
  EXPECT_EQ(labelled->display_name, "Pendulum, lab B12 \xc3\xa9");
  const std::map<std::string, std::string> want = {
      {"empty", ""}, {"plant", "pendulum"}, {"run", "7"}};
  EXPECT_EQ(labelled->labels, want);
  auto sessions = (*store)->LoadSessions();
  ASSERT_TRUE(sessions.ok());
  ASSERT_EQ(sessions->size(), 3u);
  EXPECT_EQ((*sessions)[0].labels.at("plant"), "unicycle");  // "imported"
  EXPECT_EQ((*sessions)[1].labels, want);
  EXPECT_TRUE((*sessions)[2].labels.empty());  // "plain"
  EXPECT_EQ((*sessions)[2].display_name, "");

  // Deleted with the session: a new session of that id starts without them.
  ASSERT_TRUE((*store)->DeleteSession("labelled").ok());
  ASSERT_TRUE((*store)->CreateSession(Session("labelled")).ok());
  EXPECT_TRUE((*store)->LoadSession("labelled")->labels.empty());
}

// A data directory written by a version-1 server (no display names, no labels) is
// upgraded in place at Open and keeps every session and sample.
TEST(SqliteStoreTest, MigratesVersionOneInPlace) {
  excite::testing::TempDir tmp;
  RunSql(tmp.path() + "/excite.db", R"sql(
    CREATE TABLE schema_version (version INTEGER NOT NULL);
    INSERT INTO schema_version (version) VALUES (1);
    CREATE TABLE sessions (
      id TEXT PRIMARY KEY NOT NULL,
      config BLOB NOT NULL,
      created_unix_ms INTEGER NOT NULL,
      hyperparameters BLOB NOT NULL DEFAULT x'',
      model_version INTEGER NOT NULL DEFAULT 0
    );
    CREATE TABLE samples (
      session_id TEXT NOT NULL,
      sequence INTEGER NOT NULL,
      state BLOB NOT NULL,
      input BLOB NOT NULL,
      next_state BLOB NOT NULL,
      timestamp_s REAL NOT NULL,
      PRIMARY KEY (session_id, sequence)
    ) WITHOUT ROWID;
    INSERT INTO sessions VALUES ('old', x'0802', 1600000000000, x'6879', 3);
    INSERT INTO samples VALUES ('old', 5, x'000000000000F03F', x'0000000000000040',
                                x'0000000000000840', 1.5);
  )sql");
  {
    auto store = SqliteStore::Open(tmp.path());
    ASSERT_TRUE(store.ok()) << store.status();
    auto old = (*store)->LoadSession("old");
    ASSERT_TRUE(old.ok()) << old.status();
    EXPECT_EQ(old->config, "\x08\x02");
    EXPECT_EQ(old->created_unix_ms, 1600000000000);
    EXPECT_EQ(old->hyperparameters, "hy");
    EXPECT_EQ(old->model_version, 3);
    EXPECT_EQ(old->display_name, "");
    EXPECT_TRUE(old->labels.empty());
    auto samples = (*store)->LoadSamples("old");
    ASSERT_TRUE(samples.ok());
    ASSERT_EQ(samples->size(), 1u);
    EXPECT_EQ((*samples)[0].sequence, 5);
    EXPECT_EQ((*samples)[0].state, std::vector<double>{1.0});
    EXPECT_EQ((*samples)[0].next_state, std::vector<double>{3.0});
    SessionRecord labelled = Session("new");
    labelled.labels = {{"k", "v"}};
    ASSERT_TRUE((*store)->CreateSession(labelled).ok());
  }
  // Upgraded once: the second open finds version 2.
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open((tmp.path() + "/excite.db").c_str(), &db), SQLITE_OK);
  sqlite3_stmt* stmt = nullptr;
  ASSERT_EQ(
      sqlite3_prepare_v2(db, "SELECT version FROM schema_version", -1, &stmt, nullptr),
      SQLITE_OK);
  ASSERT_EQ(sqlite3_step(stmt), SQLITE_ROW);
  EXPECT_EQ(sqlite3_column_int(stmt, 0), SqliteStore::kSchemaVersion);
  sqlite3_finalize(stmt);
  sqlite3_close(db);
  auto store = SqliteStore::Open(tmp.path());
  ASSERT_TRUE(store.ok()) << store.status();
  EXPECT_EQ((*store)->LoadSession("new")->labels.at("k"), "v");
}

TEST(SqliteStoreTest, RefusesNewerSchemaVersion) {
  excite::testing::TempDir tmp;
  { ASSERT_TRUE(SqliteStore::Open(tmp.path()).ok()); }
  RunSql(tmp.path() + "/excite.db", "UPDATE schema_version SET version = 99");
  auto store = SqliteStore::Open(tmp.path());
  EXPECT_EQ(store.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(store.status().message(), HasSubstr("schema version 99 is newer"));
}

TEST(SqliteStoreTest, RefusesUnknownSchemaVersionAndForeignDatabases) {
  excite::testing::TempDir tmp;
  { ASSERT_TRUE(SqliteStore::Open(tmp.path()).ok()); }
  RunSql(tmp.path() + "/excite.db", "UPDATE schema_version SET version = 0");
  auto store = SqliteStore::Open(tmp.path());
  EXPECT_EQ(store.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(store.status().message(), HasSubstr("unknown schema version 0"));

  excite::testing::TempDir other;
  RunSql(other.path() + "/excite.db", "CREATE TABLE foo (x INTEGER)");
  auto foreign = SqliteStore::Open(other.path());
  EXPECT_EQ(foreign.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(foreign.status().message(), HasSubstr("no schema_version table"));
}

TEST(SqliteStoreTest, SecondOpenOfSameDirectoryIsRefused) {
  excite::testing::TempDir tmp;
  auto first = SqliteStore::Open(tmp.path());
  ASSERT_TRUE(first.ok());
  auto second = SqliteStore::Open(tmp.path());
  EXPECT_EQ(second.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(second.status().message(), HasSubstr("in use"));
  first->reset();
  EXPECT_TRUE(SqliteStore::Open(tmp.path()).ok());
}

TEST(SqliteStoreTest, UsesWalAndFullSync) {
  excite::testing::TempDir tmp;
  auto store = SqliteStore::Open(tmp.path());
  ASSERT_TRUE(store.ok());
  ASSERT_TRUE((*store)->CreateSession(Session("s")).ok());
  EXPECT_TRUE(std::filesystem::exists(tmp.path() + "/excite.db-wal"));
}

}  // namespace
}  // namespace excite::store
