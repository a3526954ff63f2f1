// PostgreSQL-specific behaviour of the shared store, on a real server: leases
// and fencing between two replicas, schema creation and versioning, how the
// password is given, and recovery from a server restart.

#include "server/store/postgres_store.h"

#include <atomic>
#include <chrono>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/store/store_test_records.h"
#include "tests/support/postgres_environment.h"

namespace excite::store {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

using ::excite::store::testing::Sample;
using ::excite::store::testing::Session;

const excite::testing::PostgresEnvironment* const kPostgres =
    excite::testing::PostgresEnvironment::Register();

class PostgresStoreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    server_ = excite::testing::PostgresEnvironment::server();
    ASSERT_NE(server_, nullptr);
    dbname_ = excite::testing::PostgresEnvironment::NewDatabase("pgtest");
    ASSERT_FALSE(dbname_.empty());
  }

  PostgresStoreOptions Options(const std::string& owner,
                               std::chrono::milliseconds ttl = std::chrono::seconds(6)) {
    PostgresStoreOptions options;
    options.url = server_->url(dbname_);
    options.password = server_->password();
    options.owner = owner;
    options.lease_ttl = ttl;
    options.connect_timeout = std::chrono::seconds(5);
    return options;
  }

  std::unique_ptr<PostgresStore> Open(
      const std::string& owner, std::chrono::milliseconds ttl = std::chrono::seconds(6)) {
    absl::StatusOr<std::unique_ptr<PostgresStore>> store =
        PostgresStore::Open(Options(owner, ttl));
    EXPECT_TRUE(store.ok()) << store.status();
    return store.ok() ? *std::move(store) : nullptr;
  }

  size_t StoredSamples(PostgresStore& store, const std::string& id) {
    auto samples = store.LoadSamples(id, nullptr);
    EXPECT_TRUE(samples.ok()) << samples.status();
    return samples.ok() ? samples->size() : 0;
  }

  excite::testing::PostgresServer* server_ = nullptr;
  std::string dbname_;
};

TEST_F(PostgresStoreTest, OneOwnerAtATimeAndTheOtherIsAskedToHandOver) {
  std::unique_ptr<PostgresStore> a = Open("replica-a");
  std::unique_ptr<PostgresStore> b = Open("replica-b");
  ASSERT_TRUE(a && b);
  ASSERT_TRUE(a->CreateSession(Session("s")).ok());
  absl::StatusOr<int64_t> fence_a = a->AcquireLease("s");
  ASSERT_TRUE(fence_a.ok()) << fence_a.status();

  absl::StatusOr<int64_t> refused = b->AcquireLease("s");
  EXPECT_TRUE(absl::IsUnavailable(refused.status())) << refused.status();
  EXPECT_THAT(refused.status().message(), HasSubstr("replica-a"));
  // B's writes without a lease of its own are refused and write nothing.
  EXPECT_TRUE(absl::IsUnavailable(b->InsertSamples("s", *fence_a, {Sample(0)}).status()));
  EXPECT_EQ(StoredSamples(*a, "s"), 0u);

  // A learns that B asked, gives the session up; B takes it under a new fence.
  absl::StatusOr<LeaseRenewal> renewal = a->RenewLeases({{"s", *fence_a}});
  ASSERT_TRUE(renewal.ok()) << renewal.status();
  EXPECT_TRUE(renewal->lost.empty());
  EXPECT_THAT(renewal->wanted, ::testing::ElementsAre("s"));
  ASSERT_TRUE(a->ReleaseLease("s", *fence_a).ok());
  absl::StatusOr<int64_t> fence_b = b->AcquireLease("s");
  ASSERT_TRUE(fence_b.ok()) << fence_b.status();
  EXPECT_GT(*fence_b, *fence_a);
  ASSERT_TRUE(b->InsertSamples("s", *fence_b, {Sample(1)}).ok());

  // A, under its old fence, can write nothing any more, and its renewal says so.
  const absl::Status insert = a->InsertSamples("s", *fence_a, {Sample(2)}).status();
  EXPECT_TRUE(absl::IsUnavailable(insert)) << insert;
  EXPECT_THAT(insert.message(), HasSubstr("replica-b"));
  EXPECT_TRUE(absl::IsUnavailable(a->SaveModelState("s", *fence_a, "h", 9)));
  EXPECT_TRUE(absl::IsUnavailable(a->DeleteSession("s", *fence_a)));
  renewal = a->RenewLeases({{"s", *fence_a}});
  ASSERT_TRUE(renewal.ok());
  EXPECT_THAT(renewal->lost, ::testing::ElementsAre("s"));
  EXPECT_EQ(StoredSamples(*a, "s"), 1u);
  EXPECT_EQ(a->LoadSession("s")->model_version, 0);  // A's SaveModelState was refused
}

// A lease taken and released over and over while another replica asks for it:
// the asker gets the lease or UNAVAILABLE, never an error (a lease released
// between its take and its hand-over request once read as a NULL expiry), and
// every fence it gets is new.
TEST_F(PostgresStoreTest, AskingWhileTheLeaseChangesHandsIsOkOrUnavailable) {
  std::unique_ptr<PostgresStore> a = Open("replica-a");
  std::unique_ptr<PostgresStore> b = Open("replica-b");
  ASSERT_TRUE(a && b);
  ASSERT_TRUE(a->CreateSession(Session("s")).ok());
  std::atomic<bool> stop{false};
  std::atomic<int> a_errors{0};
  std::thread flipper([&]() {
    while (!stop.load()) {
      absl::StatusOr<int64_t> fence = a->AcquireLease("s");
      if (fence.ok()) {
        if (!a->ReleaseLease("s", *fence).ok()) ++a_errors;
      } else if (!absl::IsUnavailable(fence.status())) {
        ++a_errors;
      }
    }
  });
  int taken = 0;
  int refused = 0;
  int64_t last_fence = 0;
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(3);
  while (std::chrono::steady_clock::now() < end) {
    absl::StatusOr<int64_t> fence = b->AcquireLease("s");
    if (fence.ok()) {
      ++taken;
      EXPECT_GT(*fence, last_fence);
      last_fence = *fence;
      ASSERT_TRUE(b->ReleaseLease("s", *fence).ok());
    } else {
      ASSERT_TRUE(absl::IsUnavailable(fence.status())) << fence.status();
      ++refused;
    }
  }
  stop = true;
  flipper.join();
  EXPECT_EQ(a_errors.load(), 0);
  EXPECT_GT(taken, 0);
  EXPECT_GT(refused, 0);
}

TEST_F(PostgresStoreTest, AnExpiredLeaseIsTakenOverAndItsOldOwnerFenced) {
  const auto ttl = std::chrono::milliseconds(600);
  std::unique_ptr<PostgresStore> a = Open("replica-a", ttl);
  std::unique_ptr<PostgresStore> b = Open("replica-b", ttl);
  ASSERT_TRUE(a && b);
  ASSERT_TRUE(a->CreateSession(Session("s")).ok());
  const int64_t fence_a = *a->AcquireLease("s");
  ASSERT_TRUE(a->InsertSamples("s", fence_a, {Sample(0)}).ok());
  // A stops renewing (paused, or dead): once its lease ran out B may take it.
  std::this_thread::sleep_for(ttl + std::chrono::milliseconds(300));
  // Expired and not yet taken: A's writes are refused all the same.
  EXPECT_TRUE(absl::IsUnavailable(a->InsertSamples("s", fence_a, {Sample(1)}).status()));
  absl::StatusOr<int64_t> fence_b = b->AcquireLease("s");
  ASSERT_TRUE(fence_b.ok()) << fence_b.status();
  EXPECT_EQ(*fence_b, fence_a + 1);
  ASSERT_TRUE(b->InsertSamples("s", *fence_b, {Sample(2)}).ok());
  // A comes back: it cannot write, cannot renew, cannot take it while B renews.
  EXPECT_TRUE(absl::IsUnavailable(a->InsertSamples("s", fence_a, {Sample(3)}).status()));
  absl::StatusOr<LeaseRenewal> renewal = a->RenewLeases({{"s", fence_a}});
  ASSERT_TRUE(renewal.ok());
  EXPECT_THAT(renewal->lost, ::testing::ElementsAre("s"));
  EXPECT_TRUE(absl::IsUnavailable(a->AcquireLease("s").status()));
  auto samples = b->LoadSamples("s", nullptr);
  ASSERT_TRUE(samples.ok());
  ASSERT_EQ(samples->size(), 2u);
  EXPECT_EQ((*samples)[0].sequence, 0);
  EXPECT_EQ((*samples)[1].sequence, 2);
}

TEST_F(PostgresStoreTest, AnExpiredLeaseNobodyTookIsKeptByItsOwner) {
  const auto ttl = std::chrono::milliseconds(500);
  std::unique_ptr<PostgresStore> a = Open("replica-a", ttl);
  ASSERT_TRUE(a);
  ASSERT_TRUE(a->CreateSession(Session("s")).ok());
  const int64_t fence = *a->AcquireLease("s");
  std::this_thread::sleep_for(ttl + std::chrono::milliseconds(200));
  // Nobody else wrote meanwhile (that would have taken a new fence).
  EXPECT_EQ(*a->AcquireLease("s"), fence);
  EXPECT_TRUE(a->InsertSamples("s", fence, {Sample(0)}).ok());
}

TEST_F(PostgresStoreTest, SchemaIsCreatedOnceAndVersioned) {
  // Three replicas starting at once on an empty database.
  std::vector<std::thread> starts;
  std::atomic<int> opened{0};
  for (int i = 0; i < 3; ++i) {
    starts.emplace_back([&, i]() {
      if (PostgresStore::Open(Options(absl::StrCat("r", i))).ok()) ++opened;
    });
  }
  for (std::thread& t : starts) t.join();
  EXPECT_EQ(opened.load(), 3);
  EXPECT_EQ(*server_->Query("SELECT version FROM schema_version", dbname_), "1");
  EXPECT_EQ(*server_->Query("SELECT count(*) FROM schema_version", dbname_), "1");

  ASSERT_TRUE(server_->Query("UPDATE schema_version SET version = 99", dbname_).ok());
  absl::StatusOr<std::unique_ptr<PostgresStore>> newer =
      PostgresStore::Open(Options("r"));
  EXPECT_EQ(newer.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(newer.status().message(), HasSubstr("schema version 99, newer"));
}

TEST_F(PostgresStoreTest, RefusesADatabaseWithForeignTables) {
  ASSERT_TRUE(server_->Query("CREATE TABLE sessions (x INTEGER)", dbname_).ok());
  absl::StatusOr<std::unique_ptr<PostgresStore>> store =
      PostgresStore::Open(Options("r"));
  EXPECT_EQ(store.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(store.status().message(), HasSubstr("not written by excite-server"));
}

TEST_F(PostgresStoreTest, PasswordNeverInTheUrlAndWrongOnesRefusedAtOnce) {
  PostgresStoreOptions options = Options("r");
  options.url = absl::StrCat("postgresql://excite:", server_->password(),
                             "@127.0.0.1:", server_->port(), "/", dbname_);
  absl::StatusOr<std::unique_ptr<PostgresStore>> in_url = PostgresStore::Open(options);
  EXPECT_EQ(in_url.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(in_url.status().message(), HasSubstr("password"));
  EXPECT_THAT(in_url.status().message(), Not(HasSubstr(server_->password())));

  options = Options("r");
  options.password = "wrong";
  const auto start = std::chrono::steady_clock::now();
  absl::StatusOr<std::unique_ptr<PostgresStore>> wrong = PostgresStore::Open(options);
  EXPECT_EQ(wrong.status().code(), absl::StatusCode::kFailedPrecondition)
      << wrong.status();
  EXPECT_THAT(wrong.status().message(), Not(HasSubstr("wrong")));
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(4));

  std::unique_ptr<PostgresStore> good = Open("r");
  ASSERT_TRUE(good);
  EXPECT_EQ(
      good->location(),
      absl::StrCat("postgresql://excite@127.0.0.1:", server_->port(), "/", dbname_));
}

TEST_F(PostgresStoreTest, AnUnreachableServerIsUnavailable) {
  PostgresStoreOptions options = Options("r");
  options.url = "postgresql://excite@127.0.0.1:1/nowhere";
  options.connect_timeout = std::chrono::milliseconds(800);
  absl::StatusOr<std::unique_ptr<PostgresStore>> store = PostgresStore::Open(options);
  EXPECT_EQ(store.status().code(), absl::StatusCode::kUnavailable) << store.status();
  EXPECT_THAT(store.status().message(), HasSubstr("127.0.0.1:1"));
}

// Runs last in this binary: it restarts the shared server.
TEST_F(PostgresStoreTest, ZzRecoversFromAServerRestartWithoutReopening) {
  std::unique_ptr<PostgresStore> store = Open("replica-a");
  ASSERT_TRUE(store);
  ASSERT_TRUE(store->CreateSession(Session("s")).ok());
  const int64_t fence = *store->AcquireLease("s");
  ASSERT_TRUE(store->InsertSamples("s", fence, {Sample(0)}).ok());

  ASSERT_TRUE(server_->Stop().ok());
  const absl::Status down = store->InsertSamples("s", fence, {Sample(1)}).status();
  EXPECT_TRUE(absl::IsUnavailable(down)) << down;
  EXPECT_TRUE(absl::IsUnavailable(store->LoadSamples("s", nullptr).status()));
  ASSERT_TRUE(server_->StartAgain().ok());

  // The lease survived in the database; the same store object carries on.
  EXPECT_EQ(*store->AcquireLease("s"), fence);
  ASSERT_TRUE(store->InsertSamples("s", fence, {Sample(1)}).ok());
  EXPECT_EQ(StoredSamples(*store, "s"), 2u);
}

}  // namespace
}  // namespace excite::store
