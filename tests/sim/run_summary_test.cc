#include "sim/run_summary.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>
#include <string>

namespace excite::sim {
namespace {

RunSummary Example() {
  RunSummary summary;
  summary.system = "pendulum";
  summary.strategy = "rec";
  summary.session = "sessions/a\"b";
  summary.samples = 20;
  summary.final_rmse = 0.5;
  summary.final_rmse_per_dimension = {0.25, 0.375};
  summary.final_nlpd = -1.5;
  summary.final_inside_95 = 0.875;
  summary.rollout_rmse_10 = 0.75;  // rollout_rmse_30 left NaN: null
  summary.midway_samples = 10;
  summary.midway_rmse = 1.5;
  summary.midway_rollout_rmse_10 = 2.5;
  summary.coverage_marginal = 0.25;
  summary.coverage_joint = 0.125;
  summary.rmse_history = {{10, 1.5}, {20, 0.5}};
  summary.plan_ms_p50 = 12.0;
  summary.plans = 18;
  summary.planned_by = {{"rec", 11}, {"random", 7}};
  summary.state_names = {"theta", "theta_dot"};
  summary.state_units = {"rad", "rad/s"};
  summary.random_steps = 2;
  summary.wall_s = 3.0;
  return summary;
}

TEST(RunSummaryTest, Json) {
  EXPECT_EQ(RunSummaryToJson(Example()),
            "{\n"
            "  \"system\": \"pendulum\",\n"
            "  \"strategy\": \"rec\",\n"
            "  \"session\": \"sessions/a\\\"b\",\n"
            "  \"samples\": 20,\n"
            "  \"final_rmse\": 0.5,\n"
            "  \"final_rmse_per_dimension\": [0.25, 0.375],\n"
            "  \"state_names\": [\"theta\", \"theta_dot\"],\n"
            "  \"state_units\": [\"rad\", \"rad/s\"],\n"
            "  \"final_nlpd\": -1.5,\n"
            "  \"final_inside_95\": 0.875,\n"
            "  \"rollout_rmse_10\": 0.75,\n"
            "  \"rollout_rmse_30\": null,\n"
            "  \"midway_samples\": 10,\n"
            "  \"midway_rmse\": 1.5,\n"
            "  \"midway_rollout_rmse_10\": 2.5,\n"
            "  \"midway_rollout_rmse_30\": null,\n"
            "  \"coverage_marginal\": 0.25,\n"
            "  \"coverage_joint\": 0.125,\n"
            "  \"rmse_history\": [[10, 1.5], [20, 0.5]],\n"
            "  \"plan_ms_p50\": 12,\n"
            "  \"plans\": 18,\n"
            "  \"planned_by\": {\"random\": 7, \"rec\": 11},\n"
            "  \"random_steps\": 2,\n"
            "  \"plan_retries\": 0,\n"
            "  \"left_safe_box\": null,\n"
            "  \"wall_s\": 3,\n"
            "  \"plan_ms_p90\": 0,\n"
            "  \"plan_ms_p99\": 0,\n"
            "  \"realtime\": null\n"
            "}\n");
}

TEST(RunSummaryTest, NullForMissingJointAndNonFinite) {
  RunSummary summary = Example();
  summary.coverage_joint.reset();
  summary.final_rmse = NAN;
  summary.rmse_history = {{10, INFINITY}};
  const std::string json = RunSummaryToJson(summary);
  EXPECT_NE(json.find("\"coverage_joint\": null"), std::string::npos);
  EXPECT_NE(json.find("\"final_rmse\": null"), std::string::npos);
  EXPECT_NE(json.find("[[10, null]]"), std::string::npos);
}

TEST(RunSummaryTest, FractionOutsideTheSafeBox) {
  RunSummary summary = Example();
  summary.left_safe_box = 0.125;
  EXPECT_NE(RunSummaryToJson(summary).find("\"left_safe_box\": 0.125,"),
            std::string::npos);
}

TEST(RunSummaryTest, RoundTripsDoublesExactly) {
  RunSummary summary = Example();
  summary.final_rmse = 0.1 + 0.2;
  const std::string json = RunSummaryToJson(summary);
  const size_t at = json.find("\"final_rmse\": ") + 14;
  EXPECT_EQ(std::stod(json.substr(at)), 0.1 + 0.2);
}

TEST(RunSummaryTest, WritesFile) {
  const std::string path = testing::TempDir() + "/run_summary_test.json";
  ASSERT_TRUE(WriteRunSummary(Example(), path).ok());
  std::ifstream file(path);
  std::stringstream text;
  text << file.rdbuf();
  EXPECT_EQ(text.str(), RunSummaryToJson(Example()));
  EXPECT_FALSE(WriteRunSummary(Example(), "/nonexistent/dir/x.json").ok());
}

TEST(RunSummaryTest, RealTimeStatsInTheJson) {
  RunSummary summary = Example();
  summary.plan_ms_p90 = 40;
  summary.realtime = {20, 180, 20, 3, 1};
  const std::string json = RunSummaryToJson(summary);
  EXPECT_NE(json.find("\"plan_ms_p90\": 40,\n"), std::string::npos) << json;
  EXPECT_NE(json.find("\"realtime\": {\"hz\": 20, \"ticks_from_plan\": 180, "
                      "\"ticks_fell_back\": 20, \"late_plans\": 3, \"overruns\": 1}\n"),
            std::string::npos)
      << json;
}

// Linear interpolation between order statistics (numpy's default).
TEST(QuantileTest, InterpolatesBetweenOrderStatistics) {
  EXPECT_EQ(Quantile({}, 0.5), 0.0);
  EXPECT_EQ(Quantile({7}, 0.99), 7.0);
  EXPECT_DOUBLE_EQ(Quantile({4, 1, 3, 2, 5}, 0.9), 4.6);  // numpy.quantile: 4.6
  EXPECT_DOUBLE_EQ(Quantile({4, 1, 3, 2, 5}, 0.5), 3.0);
  EXPECT_EQ(Quantile({1, 2}, 1.0), 2.0);
}

TEST(MedianTest, OddEvenEmpty) {
  EXPECT_EQ(Median({}), 0.0);
  EXPECT_EQ(Median({3.0}), 3.0);
  EXPECT_EQ(Median({5.0, 1.0, 3.0}), 3.0);
  EXPECT_EQ(Median({4.0, 1.0, 3.0, 2.0}), 2.5);
}

}  // namespace
}  // namespace excite::sim
