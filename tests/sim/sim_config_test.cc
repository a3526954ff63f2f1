#include "sim/sim_config.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "server/service/strategy_names.h"
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

struct PaperSystem {
  const char* system;
  int state_dim;
  int input_dim;
  double noise_variance;
  int horizon;
};

class BenchmarkConfigTest : public testing::TestWithParam<PaperSystem> {};

TEST_P(BenchmarkConfigTest, ParsesValidatesAndHasThePapersNumbers) {
  const PaperSystem& paper = GetParam();
  absl::StatusOr<v1::SimConfig> config =
      LoadSimConfig(absl::StrCat(EXCITE_SIM_CONFIG_DIR, "/", paper.system, ".textproto"));
  ASSERT_TRUE(config.ok()) << config.status();
  EXPECT_TRUE(ValidateSimConfig(*config).ok()) << ValidateSimConfig(*config);
  EXPECT_EQ(config->system(), paper.system);
  absl::StatusOr<std::unique_ptr<Plant>> plant = MakePlant(config->plant());
  ASSERT_TRUE(plant.ok()) << plant.status();
  EXPECT_EQ((*plant)->name(), paper.system);
  const v1::SessionConfig& session = config->session();
  EXPECT_EQ(session.state_dim(), paper.state_dim);
  EXPECT_EQ(session.input_dim(), paper.input_dim);
  EXPECT_DOUBLE_EQ(session.noise().variance(), paper.noise_variance);
  EXPECT_EQ(session.horizon(), paper.horizon);
  EXPECT_TRUE(session.kernel().fit());
  ASSERT_EQ(config->plant().initial_state_size(), paper.state_dim);
  EXPECT_EQ(config->evaluation().seed(), 42u);

  // The initial state is a rest state: one step without input barely moves it, and
  // it lies inside the region of interest.
  Eigen::VectorXd x0(paper.state_dim);
  for (int i = 0; i < paper.state_dim; ++i) {
    x0(i) = config->plant().initial_state(i);
    EXPECT_GE(x0(i), session.state_bounds(i).lower()) << i;
    EXPECT_LE(x0(i), session.state_bounds(i).upper()) << i;
  }
  const Eigen::VectorXd x1 = (*plant)->Step(x0, Eigen::VectorXd::Zero(paper.input_dim));
  EXPECT_LT((x1 - x0).cwiseAbs().maxCoeff(), 1e-3) << (x1 - x0).transpose();
}

// The held-out plants (issue 29), their noise from bench/paper/region_rule.py.
INSTANTIATE_TEST_SUITE_P(HeldOut, BenchmarkConfigTest,
                         testing::Values(PaperSystem{"acrobot", 4, 1, 0.00681, 15},
                                         PaperSystem{"cart_pole", 4, 1, 0.00888, 15},
                                         PaperSystem{"duffing", 2, 1, 0.000392, 15}),
                         [](const testing::TestParamInfo<PaperSystem>& param_info) {
                           return std::string(param_info.param.system);
                         });

INSTANTIATE_TEST_SUITE_P(Paper, BenchmarkConfigTest,
                         testing::Values(PaperSystem{"pendulum", 2, 1, 0.05, 15},
                                         PaperSystem{"two_link", 4, 2, 0.05, 15},
                                         PaperSystem{"dipc", 8, 1, 0.05, 15},
                                         PaperSystem{"unicycle", 6, 2, 0.001, 15},
                                         PaperSystem{"half_cheetah", 18, 6, 0.001, 10}),
                         [](const testing::TestParamInfo<PaperSystem>& param_info) {
                           return std::string(param_info.param.system);
                         });

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
  EXPECT_EQ(*service::ParseStrategyName("rec"), v1::STRATEGY_REC);
  EXPECT_EQ(*service::ParseStrategyName("pa"), v1::STRATEGY_PA);
  EXPECT_EQ(*service::ParseStrategyName("greedy"), v1::STRATEGY_GREEDY);
  EXPECT_EQ(*service::ParseStrategyName("prbs"), v1::STRATEGY_PRBS);
  EXPECT_EQ(*service::ParseStrategyName("chirp"), v1::STRATEGY_CHIRP);
  EXPECT_EQ(*service::ParseStrategyName("random"), v1::STRATEGY_RANDOM);
  EXPECT_EQ(*service::ParseStrategyName("sep"), v1::STRATEGY_SEP);
  // The enum name and any case too (issue 31: one vocabulary everywhere).
  EXPECT_EQ(*service::ParseStrategyName("SEP"), v1::STRATEGY_SEP);
  EXPECT_EQ(*service::ParseStrategyName("Rec"), v1::STRATEGY_REC);
  EXPECT_EQ(*service::ParseStrategyName("STRATEGY_OPTIMISTIC"), v1::STRATEGY_OPTIMISTIC);
  EXPECT_EQ(*service::ParseStrategyName("strategy_auto"), v1::STRATEGY_AUTO);
  const absl::Status unknown = service::ParseStrategyName("p&a").status();
  EXPECT_EQ(unknown.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(unknown.message().find("expected one of rec, pa, greedy"), std::string::npos)
      << unknown;
  EXPECT_EQ(service::ParseStrategyName("STRATEGY_UNSPECIFIED").status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(service::ParseStrategyName("").status().code(),
            absl::StatusCode::kInvalidArgument);
  // Every name round-trips.
  for (const char* name : {"rec", "pa", "greedy", "prbs", "chirp", "random", "sep", "mi",
                           "roi", "optimistic", "auto"}) {
    absl::StatusOr<v1::Strategy> strategy = service::ParseStrategyName(name);
    ASSERT_TRUE(strategy.ok()) << name;
    EXPECT_EQ(service::StrategyShortName(*strategy), name);
  }
  EXPECT_EQ(service::StrategyShortName(v1::STRATEGY_PA), "pa");
  EXPECT_EQ(service::StrategyShortName(v1::STRATEGY_UNSPECIFIED), "rec");
}

}  // namespace
}  // namespace excite::sim
