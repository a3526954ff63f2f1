#include "sim/sim_config.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>

#include "absl/status/status.h"
#include "sim/plants/plant_factory.h"

namespace excite::sim {
namespace {

const std::string kPendulumConfig =
    std::string(EXCITE_SIM_CONFIG_DIR) + "/pendulum.textproto";

TEST(SimConfigTest, PendulumConfigParsesAndIsValid) {
  absl::StatusOr<v1::SimConfig> config = LoadSimConfig(kPendulumConfig);
  ASSERT_TRUE(config.ok()) << config.status();
  EXPECT_TRUE(ValidateSimConfig(*config).ok()) << ValidateSimConfig(*config);
  absl::StatusOr<std::unique_ptr<Plant>> plant = MakePlant(config->plant());
  ASSERT_TRUE(plant.ok()) << plant.status();
  EXPECT_EQ((*plant)->name(), "pendulum");
}

TEST(SimConfigTest, PendulumConfigHasThePapersNumbers) {
  const v1::SimConfig config = *LoadSimConfig(kPendulumConfig);
  EXPECT_EQ(config.system(), "pendulum");
  const v1::SessionConfig& session = config.session();
  EXPECT_EQ(session.state_dim(), 2);
  EXPECT_EQ(session.input_dim(), 1);
  EXPECT_DOUBLE_EQ(session.noise().variance(), 0.05);
  EXPECT_TRUE(session.noise().fit());
  EXPECT_TRUE(session.kernel().fit());
  EXPECT_EQ(session.horizon(), 15);
  EXPECT_EQ(session.strategy(), v1::STRATEGY_REC);
  EXPECT_EQ(session.target(), v1::TARGET_DELTA);
  EXPECT_EQ(session.refit().every_samples(), 1);
  ASSERT_EQ(config.plant().initial_state_size(), 2);
  EXPECT_EQ(config.plant().initial_state(0), 0.0);
  EXPECT_EQ(config.plant().initial_state(1), 0.0);
  EXPECT_EQ(config.evaluation().seed(), 42u);
  EXPECT_EQ(config.evaluation().points(), 1000);
  EXPECT_DOUBLE_EQ(session.state_bounds(0).upper(), M_PI);
}

TEST(SimConfigTest, MissingFileIsNotFound) {
  EXPECT_EQ(LoadSimConfig("/nonexistent/x.textproto").status().code(),
            absl::StatusCode::kNotFound);
}

TEST(SimConfigTest, ParseErrorNamesTheLine) {
  absl::StatusOr<v1::SimConfig> config =
      ParseSimConfig("system: \"p\"\nsamples: \"many\"\n");
  EXPECT_EQ(config.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(config.status().message().find("2:"), std::string::npos) << config.status();
}

TEST(SimConfigTest, ValidationErrors) {
  const v1::SimConfig good = *LoadSimConfig(kPendulumConfig);
  {
    v1::SimConfig c = good;
    c.mutable_session()->clear_state_bounds();
    EXPECT_NE(ValidateSimConfig(c).message().find("state_bounds"), std::string::npos);
  }
  {
    v1::SimConfig c = good;
    c.mutable_session()->mutable_input_bounds(0)->set_lower(5.0);
    EXPECT_NE(ValidateSimConfig(c).message().find("input_bounds"), std::string::npos);
  }
  {
    v1::SimConfig c = good;
    c.mutable_session()->set_state_dim(3);
    EXPECT_EQ(ValidateSimConfig(c).code(), absl::StatusCode::kInvalidArgument);
  }
  {
    v1::SimConfig c = good;
    c.set_samples(0);
    EXPECT_NE(ValidateSimConfig(c).message().find("samples"), std::string::npos);
  }
  {
    v1::SimConfig c = good;
    c.mutable_evaluation()->set_every_samples(0);
    EXPECT_NE(ValidateSimConfig(c).message().find("every_samples"), std::string::npos);
  }
  {
    v1::SimConfig c = good;
    c.mutable_session()->mutable_noise()->set_variance(0.0);
    EXPECT_NE(ValidateSimConfig(c).message().find("noise"), std::string::npos);
  }
  {  // The server's own rules apply to the session part.
    v1::SimConfig c = good;
    c.mutable_session()->mutable_kernel()->set_fit(false);
    const absl::Status status = ValidateSimConfig(c);
    EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(status.message().find("session."), std::string::npos) << status;
  }
  {
    v1::SimConfig c = good;
    c.mutable_plant()->clear_pendulum();
    EXPECT_NE(ValidateSimConfig(c).message().find("model"), std::string::npos);
  }
}

TEST(SimConfigTest, Overrides) {
  v1::SimConfig config = *LoadSimConfig(kPendulumConfig);
  ApplyOverrides(SimOverrides{}, &config);
  EXPECT_EQ(config.samples(), 300);
  SimOverrides overrides;
  overrides.strategy = v1::STRATEGY_PA;
  overrides.samples = 70;
  overrides.seed = 9;
  ApplyOverrides(overrides, &config);
  EXPECT_EQ(config.session().strategy(), v1::STRATEGY_PA);
  EXPECT_EQ(config.samples(), 70);
  EXPECT_EQ(config.session().seed(), 9u);
}

TEST(SimConfigTest, StrategyNames) {
  EXPECT_EQ(*ParseStrategy("rec"), v1::STRATEGY_REC);
  EXPECT_EQ(*ParseStrategy("pa"), v1::STRATEGY_PA);
  EXPECT_EQ(*ParseStrategy("greedy"), v1::STRATEGY_GREEDY);
  EXPECT_EQ(ParseStrategy("sep").status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(StrategyName(v1::STRATEGY_PA), "pa");
  EXPECT_EQ(StrategyName(v1::STRATEGY_UNSPECIFIED), "rec");
}

}  // namespace
}  // namespace excite::sim
