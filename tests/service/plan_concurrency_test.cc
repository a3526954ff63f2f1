// A session's plan runs without the session's lock: Predict, Rollout, GetSession's
// snapshot and AddData of the same session go on while it runs (reads answer
// from the model the plan uses), a second plan of the session waits for the
// first, and samples added during a plan enter the model when it ends.
#include <atomic>
#include <memory>
#include <thread>
#include <vector>

#include "absl/synchronization/notification.h"
#include "absl/time/clock.h"
#include "gtest/gtest.h"
#include "server/service/config_validation.h"
#include "server/service/session_options.h"
#include "server/service/store_conversion.h"
#include "server/session/session.h"
#include "server/store/sqlite_store.h"
#include "tests/service/pendulum_data.h"
#include "tests/service/service_fixture.h"
#include "tests/support/temp_dir.h"

namespace excite::service {
namespace {

using Clock = session::Session::Clock;

std::vector<store::SampleRecord> Records(int count, int64_t first, uint32_t seed) {
  std::vector<store::SampleRecord> records;
  for (const v1::Transition& t : testing::PendulumTransitions(count, first, seed)) {
    records.push_back(ToSampleRecord(t));
  }
  return records;
}

TEST(PlanConcurrencyTest, ReadsAndAddDataGoOnWhileTheSessionPlans) {
  testing::TempDir dir;
  absl::StatusOr<std::unique_ptr<store::SqliteStore>> store =
      store::SqliteStore::Open(dir.path());
  ASSERT_TRUE(store.ok()) << store.status();
  v1::SessionConfig config = testing::PendulumConfig();
  ASSERT_TRUE(ValidateSessionConfig(&config).ok());
  const ProtoStoredFormat format;
  absl::StatusOr<std::shared_ptr<session::Session>> created = session::Session::Create(
      "a", SessionSpecFromConfig(config), {}, &format, store->get());
  ASSERT_TRUE(created.ok()) << created.status();
  session::Session& session = **created;
  store::SessionRecord record;  // as the registry stores a new session
  record.id = "a";
  record.config = session.spec().config;
  ASSERT_TRUE((*store)->CreateSession(record).ok());
  absl::StatusOr<session::AddResult> first = session.AddSamples(Records(30, 0, 3), 1000);
  ASSERT_TRUE(first.ok()) << first.status();

  const Clock::time_point later = Clock::now() + std::chrono::minutes(5);
  const Eigen::MatrixXd z = Eigen::MatrixXd::Constant(4, 3, 0.3);
  // Fitted before the plan, so that the plan does not refit.
  absl::StatusOr<session::Prediction> before =
      session.Predict(z, false, later, later, {});
  ASSERT_TRUE(before.ok()) << before.status();

  // The plan polls `cancelled` before its solve: the first poll holds the plan
  // there until the checks below are done.
  absl::Notification planning, release;
  std::atomic<int> polls{0};
  const auto hold = [&] {
    if (polls++ == 0) {
      planning.Notify();
      release.WaitForNotification();
    }
    return false;
  };
  const Eigen::VectorXd state = Eigen::Vector2d(0.1, -0.2);
  absl::StatusOr<session::PlanResult> plan;
  std::thread planner([&] { plan = session.PlanInputs(state, {}, later, hold); });
  planning.WaitForNotification();

  absl::StatusOr<session::Prediction> during =
      session.Predict(z, false, later, later, {});
  ASSERT_TRUE(during.ok()) << during.status();
  EXPECT_EQ(during->model_version, before->model_version);
  EXPECT_EQ(during->mean, before->mean);
  absl::StatusOr<session::RolloutResult> rolled = session.Rollout(
      state, Eigen::Vector2d::Zero(), Eigen::MatrixXd::Zero(3, 1), false, later, {});
  ASSERT_TRUE(rolled.ok()) << rolled.status();
  absl::StatusOr<session::AddResult> added = session.AddSamples(Records(5, 30, 4), 1000);
  ASSERT_TRUE(added.ok()) << added.status();
  EXPECT_EQ(added->stored, 5);
  EXPECT_EQ(added->sample_count, 35);
  EXPECT_EQ(session.Snapshot().sample_count, 35);
  // Acknowledged, not yet in the model the plan uses.
  absl::StatusOr<session::Prediction> still = session.Predict(z, false, later, later, {});
  ASSERT_TRUE(still.ok()) << still.status();
  EXPECT_EQ(still->model_version, before->model_version);
  EXPECT_EQ(still->mean, before->mean);

  // A second plan of the session waits for the first.
  std::atomic<bool> second_done{false};
  absl::StatusOr<session::PlanResult> second;
  std::thread second_planner([&] {
    second = session.PlanInputs(state, {}, later, {});
    second_done = true;
  });
  absl::SleepFor(absl::Milliseconds(300));
  EXPECT_FALSE(second_done);

  release.Notify();
  planner.join();
  second_planner.join();
  ASSERT_TRUE(plan.ok()) << plan.status();
  EXPECT_EQ(plan->model_version, before->model_version);
  ASSERT_TRUE(second.ok()) << second.status();
  EXPECT_GT(second->model_version, before->model_version);
  // The 5 samples entered the model as a later version.
  absl::StatusOr<session::Prediction> after = session.Predict(z, false, later, later, {});
  ASSERT_TRUE(after.ok()) << after.status();
  EXPECT_GT(after->model_version, before->model_version);
  EXPECT_NE(after->mean, before->mean);
}

}  // namespace
}  // namespace excite::service
