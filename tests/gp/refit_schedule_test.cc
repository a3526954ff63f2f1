#include "server/gp/refit_schedule.h"

#include <gtest/gtest.h>

namespace excite::gp {
namespace {

TEST(RefitScheduleTest, EverySampleByDefault) {
  const RefitSchedule every;
  EXPECT_FALSE(RefitDue(every, 300, 0));
  EXPECT_TRUE(RefitDue(every, 301, 1));
}

TEST(RefitScheduleTest, EverySamplesCountsSinceTheLastFit) {
  const RefitSchedule schedule{3, 0.0};
  EXPECT_FALSE(RefitDue(schedule, 102, 2));
  EXPECT_TRUE(RefitDue(schedule, 103, 3));
  EXPECT_TRUE(RefitDue(schedule, 110, 10));
}

TEST(RefitScheduleTest, GrowthIsAFractionOfTheFittedSamples) {
  const RefitSchedule schedule{1, 0.05};
  // 5 % of 300 fitted samples: 15.
  EXPECT_FALSE(RefitDue(schedule, 314, 14));
  EXPECT_TRUE(RefitDue(schedule, 315, 15));
  // ceil(5 % of 310) = 16, not 15.
  EXPECT_FALSE(RefitDue(schedule, 325, 15));
  EXPECT_TRUE(RefitDue(schedule, 326, 16));
  // Below 20 fitted samples every sample is due.
  EXPECT_TRUE(RefitDue(schedule, 20, 1));
}

TEST(RefitScheduleTest, TheLargerOfTheTwoRulesDecides) {
  const RefitSchedule schedule{10, 0.01};
  EXPECT_FALSE(RefitDue(schedule, 109, 9));  // 1 % of 100 < 10
  EXPECT_TRUE(RefitDue(schedule, 110, 10));
  EXPECT_FALSE(RefitDue(schedule, 2019, 19));  // 1 % of 2000 = 20 > 10
  EXPECT_TRUE(RefitDue(schedule, 2020, 20));
}

TEST(RefitScheduleTest, ANeverFittedModelIsDueOnceItHasEverySamples) {
  const RefitSchedule schedule{2, 0.5};
  EXPECT_FALSE(RefitDue(schedule, 1, 1));
  EXPECT_TRUE(RefitDue(schedule, 2, 2));
}

}  // namespace
}  // namespace excite::gp
