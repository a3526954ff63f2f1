// Display names, labels and creation times of sessions (AIP-148): validation,
// ListSessions' label filter, and that they survive a restart and an export and
// import.

#include "server/service/session_labels.h"

#include <chrono>
#include <string>
#include <vector>

#include "client/excite_client.h"
#include "gmock/gmock.h"
#include "google/protobuf/util/message_differencer.h"
#include "google/protobuf/util/time_util.h"
#include "google/rpc/error_details.pb.h"
#include "gtest/gtest.h"
#include "tests/service/service_fixture.h"

namespace excite::service {
namespace {

using ::excite::testing::BadRequestOf;
using ::excite::testing::ExpectStatus;
using ::excite::testing::PendulumConfig;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ServiceTest = ::excite::testing::ServiceTest;

bool Matches(const std::string& filter, const Labels& labels) {
  absl::StatusOr<LabelFilter> parsed = LabelFilter::Parse(filter);
  EXPECT_TRUE(parsed.ok()) << filter << ": " << parsed.status();
  return parsed.ok() && parsed->Matches(labels);
}

TEST(LabelFilterTest, MatchesEqualsNotEqualsAndHas) {
  const Labels labels = {{"plant", "pendulum"}, {"run", "7"}, {"empty", ""}};
  EXPECT_TRUE(Matches("", labels));
  EXPECT_TRUE(Matches("  ", {}));
  EXPECT_TRUE(Matches("labels.plant = \"pendulum\"", labels));
  EXPECT_TRUE(Matches("labels.plant=pendulum", labels));
  EXPECT_FALSE(Matches("labels.plant = \"unicycle\"", labels));
  EXPECT_FALSE(Matches("labels.missing = \"\"", labels));  // absent is not ""
  EXPECT_TRUE(Matches("labels.empty = \"\"", labels));
  EXPECT_TRUE(Matches("labels.plant != \"unicycle\"", labels));
  EXPECT_TRUE(Matches("labels.missing != \"x\"", labels));
  EXPECT_FALSE(Matches("labels.run != 7", labels));
  EXPECT_TRUE(Matches("labels.run:*", labels));
  EXPECT_FALSE(Matches("labels.lab:*", labels));
  EXPECT_TRUE(
      Matches("labels.plant = pendulum AND labels.run:* AND labels.lab != b12", labels));
  EXPECT_FALSE(Matches("labels.plant = pendulum AND labels.lab:*", labels));
}

TEST(LabelFilterTest, ErrorsSayWhatIsWrongAndWhatIsAllowed) {
  for (const char* bad : {"plant = pendulum", "labels.plant ~ x", "labels.Plant = x",
                          "labels.plant = \"Pen dulum\"", "labels.plant:x",
                          "labels.plant = a OR labels.run:*", "labels.plant = a AND "}) {
    absl::StatusOr<LabelFilter> parsed = LabelFilter::Parse(bad);
    ASSERT_FALSE(parsed.ok()) << bad;
    EXPECT_EQ(parsed.status().code(), absl::StatusCode::kInvalidArgument) << bad;
    EXPECT_THAT(parsed.status().message(), HasSubstr("filter: \"")) << bad;
    EXPECT_THAT(parsed.status().message(), HasSubstr("want conditions joined by AND"))
        << bad;
  }
  // A lowercase and is said to be one (it used to be read as part of a value).
  for (const char* joined :
       {"labels.plant = a and labels.run:*", "labels.plant = a or labels.run:*"}) {
    absl::StatusOr<LabelFilter> parsed = LabelFilter::Parse(joined);
    ASSERT_FALSE(parsed.ok()) << joined;
    EXPECT_THAT(parsed.status().message(),
                HasSubstr("join conditions with AND in capitals"))
        << joined;
  }
}

v1::CreateSessionRequest Labelled(const std::string& id, const std::string& plant) {
  v1::CreateSessionRequest request;
  request.set_session_id(id);
  *request.mutable_config() = PendulumConfig();
  request.set_display_name("Session " + id);
  (*request.mutable_labels())["plant"] = plant;
  (*request.mutable_labels())["lab"] = "b12";
  return request;
}

std::vector<std::string> ListedIds(client::ExciteClient* client,
                                   const std::string& filter, int page_size = 0) {
  std::vector<std::string> ids;
  std::string token;
  do {
    absl::StatusOr<v1::ListSessionsResponse> page =
        client->ListSessions(page_size, token, filter);
    EXPECT_TRUE(page.ok()) << page.status();
    if (!page.ok()) break;
    for (const v1::Session& s : page->sessions()) ids.push_back(s.name().substr(9));
    token = page->next_page_token();
  } while (!token.empty());
  return ids;
}

TEST_F(ServiceTest, DisplayNameLabelsAndCreateTimeAreKeptAndFilterable) {
  const auto before = std::chrono::system_clock::now();
  absl::StatusOr<v1::Session> created =
      client_->CreateSession(Labelled("p1", "pendulum"));
  ASSERT_TRUE(created.ok()) << created.status();
  const auto after = std::chrono::system_clock::now();
  EXPECT_EQ(created->display_name(), "Session p1");
  EXPECT_EQ(created->labels().at("plant"), "pendulum");
  EXPECT_EQ(created->labels().size(), 2u);
  const int64_t created_ms =
      google::protobuf::util::TimeUtil::TimestampToMilliseconds(created->create_time());
  EXPECT_GE(created_ms, std::chrono::duration_cast<std::chrono::milliseconds>(
                            before.time_since_epoch())
                            .count());
  EXPECT_LE(created_ms, std::chrono::duration_cast<std::chrono::milliseconds>(
                            after.time_since_epoch())
                            .count());
  ASSERT_TRUE(client_->CreateSession(Labelled("p2", "pendulum")).ok());
  ASSERT_TRUE(client_->CreateSession(Labelled("u1", "unicycle")).ok());
  Create("plain");

  EXPECT_THAT(ListedIds(client_.get(), ""), ElementsAre("p1", "p2", "plain", "u1"));
  EXPECT_THAT(ListedIds(client_.get(), "labels.plant = \"pendulum\""),
              ElementsAre("p1", "p2"));
  EXPECT_THAT(ListedIds(client_.get(), "labels.plant = pendulum", 1),
              ElementsAre("p1", "p2"));
  EXPECT_THAT(ListedIds(client_.get(), "labels.lab:* AND labels.plant != pendulum"),
              ElementsAre("u1"));
  EXPECT_THAT(ListedIds(client_.get(), "labels.plant = cartpole"), ElementsAre());
  ExpectStatus(client_->ListSessions(0, "", "plant = pendulum").status(),
               absl::StatusCode::kInvalidArgument, "only labels can be filtered on");

  // A restart reads them back from the store.
  StopServer();
  StartServer();
  absl::StatusOr<v1::Session> restored = client_->GetSession("sessions/p1");
  ASSERT_TRUE(restored.ok()) << restored.status();
  // Equals: a map's serialized order is not fixed.
  EXPECT_TRUE(google::protobuf::util::MessageDifferencer::Equals(*restored, *created))
      << restored->DebugString() << " vs " << created->DebugString();
  EXPECT_THAT(ListedIds(client_.get(), "labels.plant = pendulum"),
              ElementsAre("p1", "p2"));

  // Export and import keep them, the creation time too.
  absl::StatusOr<v1::SessionArchive> archive = client_->ExportSession("sessions/u1");
  ASSERT_TRUE(archive.ok()) << archive.status();
  EXPECT_EQ(archive->display_name(), "Session u1");
  absl::StatusOr<v1::Session> imported = client_->ImportSession(*archive, "u1-copy");
  ASSERT_TRUE(imported.ok()) << imported.status();
  const v1::Session original = *client_->GetSession("sessions/u1");
  EXPECT_EQ(imported->display_name(), original.display_name());
  EXPECT_EQ(imported->labels().at("plant"), "unicycle");
  EXPECT_EQ(imported->create_time().seconds(), original.create_time().seconds());
  EXPECT_THAT(ListedIds(client_.get(), "labels.plant = unicycle"),
              ElementsAre("u1", "u1-copy"));
}

TEST_F(ServiceTest, BadLabelsAreRefusedWithEveryProblemAndNothingIsStored) {
  v1::CreateSessionRequest request = Labelled("bad", "pendulum");
  (*request.mutable_labels())["Upper"] = "x";
  (*request.mutable_labels())["ok"] = "Not Allowed";
  request.set_display_name(std::string(257, 'a'));
  request.mutable_config()->mutable_noise()->set_variance(-1);
  grpc::ClientContext context;
  v1::Session ignored;
  const grpc::Status status = stub_->CreateSession(&context, request, &ignored);
  ASSERT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(status.error_message(), HasSubstr("4 problems: "));
  const google::rpc::BadRequest bad = BadRequestOf(status);
  std::vector<std::string> fields;
  for (const auto& v : bad.field_violations()) fields.push_back(v.field());
  EXPECT_THAT(fields, ElementsAre("config.noise.variance", "display_name",
                                  "labels[\"Upper\"]", "labels[\"ok\"]"));
  EXPECT_THAT(bad.field_violations(1).description(), HasSubstr("at most 256 characters"));
  ExpectStatus(client_->GetSession("sessions/bad").status(), absl::StatusCode::kNotFound,
               "not found");

  v1::CreateSessionRequest control = Labelled("ctl", "pendulum");
  control.set_display_name("tab\there");
  EXPECT_EQ(client_->CreateSession(control).status().code(),
            absl::StatusCode::kInvalidArgument);
  v1::CreateSessionRequest many = Labelled("many", "pendulum");
  for (int i = 0; i < 64; ++i) (*many.mutable_labels())["k" + std::to_string(i)] = "v";
  ExpectStatus(client_->CreateSession(many).status(), absl::StatusCode::kInvalidArgument,
               "at most 64 labels, got 66");
}

}  // namespace
}  // namespace excite::service
