// SQLite-specific behaviour of the embedded store: files, migration, the data
// directory's lock. What every store does is in session_store_conformance_test.
#include "server/store/sqlite_store.h"

#include <sqlite3.h>

#include <filesystem>
#include <string>
#include <vector>

#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/store/store_test_records.h"
#include "tests/support/temp_dir.h"

namespace excite::store {
namespace {

using ::testing::HasSubstr;

using ::excite::store::testing::Session;

TEST(SqliteStoreTest, OpenCreatesDirectoryAndDatabase) {
  excite::testing::TempDir tmp;
  const std::string dir = tmp.path() + "/nested/data";
  auto store = SqliteStore::Open(dir);
  ASSERT_TRUE(store.ok()) << store.status();
  EXPECT_TRUE(std::filesystem::exists(dir + "/excite.db"));
  EXPECT_EQ((*store)->location(), dir + "/excite.db");
}

void RunSql(const std::string& db_path, const char* sql) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(db_path.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db, sql, nullptr, nullptr, nullptr), SQLITE_OK)
      << sqlite3_errmsg(db);
  sqlite3_close(db);
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
    auto samples = (*store)->LoadSamples("old", nullptr);
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
