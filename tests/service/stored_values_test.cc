// No stored value may make a later read fail: times and integers of an archive
// are range-checked when it comes in, what an older server (or a hand) left in
// the store is converted back clamped, and an error reply stays small enough
// for a client's metadata limit however bad the request was.

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "google/protobuf/util/time_util.h"
#include "gtest/gtest.h"
#include "sqlite3.h"
#include "tests/service/pendulum_data.h"
#include "tests/service/service_fixture.h"

namespace excite::testing {
namespace {

using ::google::protobuf::util::TimeUtil;

// google.protobuf.Timestamp's largest time, 9999-12-31T23:59:59.999Z, in ms.
constexpr int64_t kLastMillisecond = 253402300799999;

class StoredValuesTest : public ServiceTest {
 protected:
  void Sql(const std::string& statements) {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open((options_.data_dir + "/excite.db").c_str(), &db), SQLITE_OK);
    char* error = nullptr;
    EXPECT_EQ(sqlite3_exec(db, statements.c_str(), nullptr, nullptr, &error), SQLITE_OK)
        << (error != nullptr ? error : "");
    sqlite3_free(error);
    sqlite3_close(db);
  }
};

// The import: created_unix_ms one past Timestamp's range was stored,
// answered INTERNAL, and broke ListSessions for everyone, also after a restart.
TEST_F(StoredValuesTest, ACreationTimePastTheYear9999IsRefusedAndStoresNothing) {
  for (int64_t created : {kLastMillisecond + 1, (int64_t{1} << 53) + 1, int64_t{1} << 62,
                          std::numeric_limits<int64_t>::max(), int64_t{-1},
                          std::numeric_limits<int64_t>::min()}) {
    SCOPED_TRACE(created);
    v1::SessionArchive archive = PendulumArchive("far");
    archive.set_created_unix_ms(created);
    ExpectStatus(client_->ImportSession(archive).status(),
                 absl::StatusCode::kInvalidArgument,
                 "archive.created_unix_ms: must be in");
    EXPECT_EQ(ExpectEveryReadSucceeds(), 0);
  }
  // The last millisecond of 9999 is accepted and kept across export and import.
  v1::SessionArchive archive = PendulumArchive("edge");
  archive.set_created_unix_ms(kLastMillisecond);
  absl::StatusOr<v1::Session> imported = client_->ImportSession(archive);
  ASSERT_TRUE(imported.ok()) << imported.status();
  EXPECT_EQ(TimeUtil::TimestampToMilliseconds(imported->create_time()), kLastMillisecond);
  EXPECT_EQ(ExpectEveryReadSucceeds(), 1);
  absl::StatusOr<v1::SessionArchive> exported = client_->ExportSession("sessions/edge");
  ASSERT_TRUE(exported.ok()) << exported.status();
  EXPECT_EQ(exported->created_unix_ms(), kLastMillisecond);
  StopServer();
  StartServer();
  EXPECT_EQ(ExpectEveryReadSucceeds(), 1);
}

// Rows an older server accepted (or a hand wrote): every read still answers,
// the time clamped to what the wire can carry, and the export imports again.
TEST_F(StoredValuesTest, OutOfRangeStoredTimesAreClampedOnTheWayOut) {
  Create("future");
  Create("past");
  Create("fine");
  StopServer();
  Sql(absl::StrCat("UPDATE sessions SET created_unix_ms = ",
                   std::numeric_limits<int64_t>::max(), " WHERE id = 'future';",
                   "UPDATE sessions SET created_unix_ms = -5 WHERE id = 'past';"));
  StartServer();
  EXPECT_EQ(ExpectEveryReadSucceeds(), 3);
  absl::StatusOr<v1::Session> future = client_->GetSession("sessions/future");
  ASSERT_TRUE(future.ok()) << future.status();
  EXPECT_EQ(TimeUtil::TimestampToMilliseconds(future->create_time()), kLastMillisecond);
  absl::StatusOr<v1::Session> past = client_->GetSession("sessions/past");
  ASSERT_TRUE(past.ok()) << past.status();
  EXPECT_FALSE(past->has_create_time());  // unknown
  absl::StatusOr<v1::SessionArchive> exported = client_->ExportSession("sessions/future");
  ASSERT_TRUE(exported.ok()) << exported.status();
  EXPECT_EQ(exported->created_unix_ms(), kLastMillisecond);
  ASSERT_TRUE(client_->ImportSession(*exported, "future-again").ok());
  EXPECT_EQ(ExpectEveryReadSucceeds(), 4);
}

// A session whose stored config no longer parses: Predict's advice says the
// export reads what is readable, and it does (the samples and the config's
// bytes); the archive imports once a config is set.
TEST_F(StoredValuesTest, TheExportOfADamagedConfigGivesTheSamplesAsAdvised) {
  const std::string name = Create("broken").name();
  Add(name, {PendulumTransitions(10, 0, 4)});
  StopServer();
  Sql("UPDATE sessions SET config = x'ffffffff', hyperparameters = x'ff' "
      "WHERE id = 'broken';");
  StartServer();
  v1::PredictRequest predict;
  predict.set_session(name);
  for (double v : {0.1, -0.2, 0.3}) predict.add_inputs(v);
  ExpectStatus(client_->Predict(predict).status(), absl::StatusCode::kDataLoss,
               "ExportSession reads what is readable");
  absl::StatusOr<v1::SessionArchive> exported = client_->ExportSession(name);
  ASSERT_TRUE(exported.ok()) << exported.status();
  EXPECT_EQ(exported->samples_size(), 10);
  EXPECT_FALSE(exported->has_config());
  EXPECT_EQ(exported->unreadable_config(), std::string(4, '\xff'));
  EXPECT_EQ(exported->hyperparameters_size(), 0);

  v1::SessionArchive archive = *exported;
  ExpectStatus(client_->ImportSession(archive, "repaired").status(),
               absl::StatusCode::kInvalidArgument,
               "archive.config: unset: the archive was exported from a session whose "
               "stored config does not parse");
  *archive.mutable_config() = PendulumConfig();
  absl::StatusOr<v1::Session> repaired = client_->ImportSession(archive, "repaired");
  ASSERT_TRUE(repaired.ok()) << repaired.status();
  EXPECT_EQ(repaired->sample_count(), 10);
  predict.set_session(repaired->name());
  EXPECT_TRUE(client_->Predict(predict).ok());
}

// Each request's error names every problem it can within a client's metadata
// limit: before the cap, these got RESOURCE_EXHAUSTED ("received initial
// metadata size exceeds limit") instead of INVALID_ARGUMENT.
TEST_F(StoredValuesTest, ErrorsOfHugelyBadRequestsStayInvalidArgument) {
  const auto expect_small = [](const grpc::Status& status, const std::string& part) {
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT)
        << status.error_message().substr(0, 300);
    EXPECT_LE(status.error_message().size(), 800u);
    EXPECT_NE(status.error_message().find(part), std::string::npos)
        << status.error_message();
    const google::rpc::BadRequest bad = BadRequestOf(status);
    EXPECT_GE(bad.field_violations_size(), 1);
    EXPECT_LE(bad.field_violations_size(), 10);
  };
  {
    // 1000 bad labels.
    v1::CreateSessionRequest request;
    *request.mutable_config() = PendulumConfig();
    request.set_session_id("labelled");
    for (int i = 0; i < 1000; ++i) {
      (*request.mutable_labels())[absl::StrCat("Bad Key ", i)] = "Bad Value";
    }
    v1::Session session;
    grpc::ClientContext context;
    expect_small(stub_->CreateSession(&context, request, &session), "more");
  }
  {
    // 100 state dimensions, each with an empty interval.
    v1::CreateSessionRequest request;
    v1::SessionConfig* config = request.mutable_config();
    *config = PendulumConfig();
    config->set_state_dim(100);
    config->clear_state_bounds();
    for (int i = 0; i < 100; ++i) {
      v1::Interval* bound = config->add_state_bounds();
      bound->set_lower(1.0);
      bound->set_upper(-1.0);
    }
    v1::Session session;
    grpc::ClientContext context;
    expect_small(stub_->CreateSession(&context, request, &session), "more");
  }
  {
    // An 18 KB filter that does not parse, quoted back in the message.
    v1::ListSessionsRequest request;
    request.set_filter(std::string(18000, 'x'));
    v1::ListSessionsResponse response;
    grpc::ClientContext context;
    expect_small(stub_->ListSessions(&context, request, &response), "more bytes");
  }
  EXPECT_EQ(ExpectEveryReadSucceeds(), 0);
}

}  // namespace
}  // namespace excite::testing
