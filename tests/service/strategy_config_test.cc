// Config validation of the strategies added after rec/pa/greedy: prbs, chirp,
// random (SignalConfig), sep (SepConfig, state_bounds), mi, roi (RoiConfig,
// state_bounds), and the safe box of every model-based strategy (SafetyConfig).
#include <cmath>
#include <string>
#include <vector>

#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "server/service/config_text.h"
#include "server/service/config_validation.h"
#include "server/service/session_options.h"
#include "server/service/strategy_names.h"

namespace excite::service {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;

constexpr char kPendulum[] = R"pb(
  state_dim: 2
  input_dim: 1
  input_bounds { lower: -3 upper: 3 }
  state_bounds { lower: -3.2 upper: 3.2 }
  state_bounds { lower: -8 upper: 8 }
  noise { variance: 0.05 fit: true }
  kernel { fit: true }
)pb";

v1::SessionConfig Config(v1::Strategy strategy) {
  absl::StatusOr<v1::SessionConfig> config = ParseSessionConfigText(kPendulum);
  EXPECT_TRUE(config.ok()) << config.status();
  config->set_strategy(strategy);
  return *config;
}

void ExpectInvalid(v1::SessionConfig config, const std::string& field,
                   const std::string& what = "") {
  const absl::Status status = ValidateSessionConfig(&config);
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument) << status;
  EXPECT_THAT(std::string(status.message()), StartsWith(field + ":")) << status;
  EXPECT_THAT(std::string(status.message()), HasSubstr(what)) << status;
}

// Every strategy of the wire has its row in the engine's table under its short
// name, and every row is on the wire: adding one means the proto enum and the row.
TEST(StrategyConfigTest, TheWireAndTheTableNameTheSameStrategies) {
  const google::protobuf::EnumDescriptor* enums = v1::Strategy_descriptor();
  int on_the_wire = 0;
  for (int i = 0; i < enums->value_count(); ++i) {
    const auto strategy = static_cast<v1::Strategy>(enums->value(i)->number());
    if (strategy == v1::STRATEGY_UNSPECIFIED) continue;
    ++on_the_wire;
    const std::string name = StrategyShortName(strategy);
    const plan::StrategyInfo* info = plan::FindStrategy(name);
    ASSERT_NE(info, nullptr) << name << " has no row in plan/strategy.cc";
    EXPECT_EQ(&EngineStrategy(strategy), info);
    EXPECT_EQ(PlanOptionsFromConfig(Config(strategy)).strategy, info->strategy);
    EXPECT_EQ(*ParseStrategyName(name), strategy);
  }
  EXPECT_EQ(on_the_wire, static_cast<int>(plan::Strategies().size()));
  EXPECT_EQ(StrategyShortName(v1::STRATEGY_UNSPECIFIED), "rec");
  EXPECT_THAT(std::string(ParseStrategyName("foo").status().message()),
              HasSubstr("expected one of rec, pa, greedy"));
}

TEST(StrategyConfigTest, DefaultsAreFilledOnlyForTheSessionsStrategy) {
  v1::SessionConfig c = Config(v1::STRATEGY_PRBS);
  ASSERT_TRUE(ValidateSessionConfig(&c).ok());
  EXPECT_EQ(c.signal().prbs_min_hold(), 5);
  EXPECT_EQ(c.signal().chirp_period(), 0);
  EXPECT_EQ(c.signal().random_hold(), 0);
  EXPECT_FALSE(c.has_sep());
  EXPECT_EQ(c.horizon(), 15);

  c = Config(v1::STRATEGY_CHIRP);
  ASSERT_TRUE(ValidateSessionConfig(&c).ok());
  EXPECT_EQ(c.signal().chirp_start_frequency(), 0.01);
  EXPECT_EQ(c.signal().chirp_end_frequency(), 0.2);
  EXPECT_EQ(c.signal().chirp_period(), 200);
  EXPECT_EQ(c.signal().prbs_min_hold(), 0);

  c = Config(v1::STRATEGY_RANDOM);
  ASSERT_TRUE(ValidateSessionConfig(&c).ok());
  EXPECT_EQ(c.signal().random_hold(), 1);

  c = Config(v1::STRATEGY_SEP);
  ASSERT_TRUE(ValidateSessionConfig(&c).ok());
  EXPECT_EQ(c.sep().search_starts(), 4);
  EXPECT_EQ(c.sep().search_samples(), 256);
  EXPECT_EQ(c.sep().search_iterations(), 50);
  EXPECT_FALSE(c.has_signal());

  // The existing strategies' stored configs do not grow new sections.
  for (v1::Strategy s : {v1::STRATEGY_REC, v1::STRATEGY_PA, v1::STRATEGY_GREEDY}) {
    c = Config(s);
    ASSERT_TRUE(ValidateSessionConfig(&c).ok());
    EXPECT_FALSE(c.has_signal());
    EXPECT_FALSE(c.has_sep());
  }

  // Idempotent, and explicit values are kept.
  c = Config(v1::STRATEGY_CHIRP);
  c.mutable_signal()->set_chirp_start_frequency(0.3);
  c.mutable_signal()->set_chirp_end_frequency(0.05);
  c.mutable_signal()->set_chirp_period(60);
  ASSERT_TRUE(ValidateSessionConfig(&c).ok());
  v1::SessionConfig again = c;
  ASSERT_TRUE(ValidateSessionConfig(&again).ok());
  EXPECT_EQ(again.SerializeAsString(), c.SerializeAsString());
  EXPECT_EQ(c.signal().chirp_start_frequency(), 0.3);
  EXPECT_EQ(c.signal().chirp_period(), 60);
}

TEST(StrategyConfigTest, SepNeedsStateBounds) {
  v1::SessionConfig c = Config(v1::STRATEGY_SEP);
  c.clear_state_bounds();
  ExpectInvalid(c, "config.state_bounds", "STRATEGY_SEP needs state_dim (2)");
  // Other strategies still work without them.
  for (v1::Strategy s :
       {v1::STRATEGY_REC, v1::STRATEGY_PRBS, v1::STRATEGY_CHIRP, v1::STRATEGY_RANDOM}) {
    c = Config(s);
    c.clear_state_bounds();
    EXPECT_TRUE(ValidateSessionConfig(&c).ok()) << v1::Strategy_Name(s);
  }
}

TEST(StrategyConfigTest, InvalidParametersNameTheField) {
  v1::SessionConfig c = Config(v1::STRATEGY_PRBS);
  c.mutable_signal()->set_prbs_min_hold(-2);
  ExpectInvalid(c, "config.signal.prbs_min_hold", "[1, 1000000]");
  c = Config(v1::STRATEGY_CHIRP);
  c.mutable_signal()->set_chirp_start_frequency(0.7);
  ExpectInvalid(c, "config.signal.chirp_start_frequency", "(0, 0.5]");
  c = Config(v1::STRATEGY_CHIRP);
  c.mutable_signal()->set_chirp_end_frequency(-0.1);
  ExpectInvalid(c, "config.signal.chirp_end_frequency");
  c = Config(v1::STRATEGY_CHIRP);
  c.mutable_signal()->set_chirp_end_frequency(std::nan(""));
  ExpectInvalid(c, "config.signal.chirp_end_frequency");
  c = Config(v1::STRATEGY_CHIRP);
  c.mutable_signal()->set_chirp_period(-1);
  ExpectInvalid(c, "config.signal.chirp_period");
  c = Config(v1::STRATEGY_RANDOM);
  c.mutable_signal()->set_random_hold(-1);
  ExpectInvalid(c, "config.signal.random_hold");
  c = Config(v1::STRATEGY_SEP);
  c.mutable_sep()->set_search_starts(101);
  ExpectInvalid(c, "config.sep.search_starts", "[1, 100]");
  c = Config(v1::STRATEGY_SEP);
  c.mutable_sep()->set_search_samples(-5);
  ExpectInvalid(c, "config.sep.search_samples");
  c = Config(v1::STRATEGY_SEP);
  c.mutable_sep()->set_search_iterations(10001);
  ExpectInvalid(c, "config.sep.search_iterations");
  // A set but invalid value is rejected whatever the strategy.
  c = Config(v1::STRATEGY_REC);
  c.mutable_signal()->set_random_hold(-1);
  ExpectInvalid(c, "config.signal.random_hold");
}

TEST(StrategyConfigTest, PlanOptionsFromConfig) {
  v1::SessionConfig c = Config(v1::STRATEGY_SEP);
  c.mutable_sep()->set_search_starts(7);
  ASSERT_TRUE(ValidateSessionConfig(&c).ok());
  plan::PlanOptions o = PlanOptionsFromConfig(c);
  EXPECT_EQ(o.strategy, plan::Strategy::kSep);
  ASSERT_EQ(o.state_lower.size(), 2);
  EXPECT_EQ(o.state_lower(1), -8.0);
  EXPECT_EQ(o.state_upper(0), 3.2);
  EXPECT_EQ(o.sep.search_starts, 7);
  EXPECT_EQ(o.sep.search_samples, 256);

  c = Config(v1::STRATEGY_CHIRP);
  c.mutable_signal()->set_chirp_period(33);
  ASSERT_TRUE(ValidateSessionConfig(&c).ok());
  o = PlanOptionsFromConfig(c);
  EXPECT_EQ(o.strategy, plan::Strategy::kChirp);
  EXPECT_EQ(o.signal.chirp_period, 33);
  EXPECT_EQ(o.signal.chirp_end_frequency, 0.2);
  EXPECT_EQ(PlanOptionsFromConfig(Config(v1::STRATEGY_PRBS)).strategy,
            plan::Strategy::kPrbs);
  EXPECT_EQ(PlanOptionsFromConfig(Config(v1::STRATEGY_RANDOM)).strategy,
            plan::Strategy::kRandom);
}

TEST(StrategyConfigTest, MiAndRoi) {
  v1::SessionConfig c = Config(v1::STRATEGY_ROI);
  ASSERT_TRUE(ValidateSessionConfig(&c).ok());
  EXPECT_EQ(c.roi().reference_points(), 256);
  plan::PlanOptions o = PlanOptionsFromConfig(c);
  EXPECT_EQ(o.strategy, plan::Strategy::kRoi);
  EXPECT_EQ(o.roi_reference_points, 256);
  c = Config(v1::STRATEGY_ROI);
  c.mutable_roi()->set_reference_points(4097);
  ExpectInvalid(c, "config.roi.reference_points", "[1, 4096]");
  c = Config(v1::STRATEGY_ROI);
  c.clear_state_bounds();
  ExpectInvalid(c, "config.state_bounds", "STRATEGY_ROI needs state_dim (2)");
  c = Config(v1::STRATEGY_ROI);
  c.mutable_roi()->set_reference_points(64);
  ASSERT_TRUE(ValidateSessionConfig(&c).ok());
  EXPECT_EQ(PlanOptionsFromConfig(c).roi_reference_points, 64);

  c = Config(v1::STRATEGY_MI);
  c.clear_state_bounds();
  ASSERT_TRUE(ValidateSessionConfig(&c).ok());
  EXPECT_FALSE(c.has_roi());
  EXPECT_EQ(PlanOptionsFromConfig(c).strategy, plan::Strategy::kMi);
}

TEST(StrategyConfigTest, Optimistic) {
  v1::SessionConfig c = Config(v1::STRATEGY_OPTIMISTIC);
  ASSERT_TRUE(ValidateSessionConfig(&c).ok());
  EXPECT_EQ(c.optimistic().beta(), 1.0);  // the default is filled in
  plan::PlanOptions o = PlanOptionsFromConfig(c);
  EXPECT_EQ(o.strategy, plan::Strategy::kOptimistic);
  EXPECT_EQ(o.optimism_beta, 1.0);
  c.mutable_optimistic()->set_beta(2.5);
  ASSERT_TRUE(ValidateSessionConfig(&c).ok());
  EXPECT_EQ(PlanOptionsFromConfig(c).optimism_beta, 2.5);
  for (double bad : {0.0, -1.0, 10.5, std::nan(""), HUGE_VAL}) {
    c = Config(v1::STRATEGY_OPTIMISTIC);
    c.mutable_optimistic()->set_beta(bad);
    ExpectInvalid(c, "config.optimistic.beta", "(0, 10]");
  }
  // Another strategy: not filled in, but a set value is still checked.
  c = Config(v1::STRATEGY_REC);
  ASSERT_TRUE(ValidateSessionConfig(&c).ok());
  EXPECT_FALSE(c.has_optimistic());
  c.mutable_optimistic()->set_beta(-2.0);
  ExpectInvalid(c, "config.optimistic.beta");
}

// The bandit chooser: its members and their blocks' defaults.
TEST(StrategyConfigTest, AutoFillsItsMembersAndTheirDefaults) {
  const auto bandit = [] {
    v1::SessionConfig c = Config(v1::STRATEGY_AUTO);
    c.mutable_auto_()->set_chooser(v1::AutoConfig::CHOOSER_BANDIT);
    return c;
  };
  v1::SessionConfig c = bandit();
  ASSERT_TRUE(ValidateSessionConfig(&c).ok());
  EXPECT_THAT(c.auto_().members(),
              ::testing::ElementsAre(v1::STRATEGY_REC, v1::STRATEGY_OPTIMISTIC,
                                     v1::STRATEGY_ROI, v1::STRATEGY_RANDOM));
  // The members' blocks get their defaults; roi keeps the GP exact.
  EXPECT_EQ(c.optimistic().beta(), 1.0);
  EXPECT_EQ(c.roi().reference_points(), 256);
  EXPECT_EQ(c.signal().random_hold(), 1);
  EXPECT_EQ(c.sparse().above_samples(), 0);
  plan::PlanOptions o = PlanOptionsFromConfig(c);
  EXPECT_EQ(o.strategy, plan::Strategy::kAuto);
  EXPECT_EQ(o.auto_chooser, plan::AutoChooser::kBandit);
  EXPECT_EQ(o.auto_members, (std::vector<plan::Strategy>{
                                plan::Strategy::kRec, plan::Strategy::kOptimistic,
                                plan::Strategy::kRoi, plan::Strategy::kRandom}));
  EXPECT_TRUE(o.Validate(2, 1).ok());

  // Without state bounds roi is left out, and the GP may turn sparse.
  c = bandit();
  c.clear_state_bounds();
  ASSERT_TRUE(ValidateSessionConfig(&c).ok());
  EXPECT_THAT(c.auto_().members(),
              ::testing::ElementsAre(v1::STRATEGY_REC, v1::STRATEGY_OPTIMISTIC,
                                     v1::STRATEGY_RANDOM));
  EXPECT_GT(c.sparse().above_samples(), 0);

  // Named members are kept as named.
  c = bandit();
  c.mutable_auto_()->add_members(v1::STRATEGY_MI);
  c.mutable_auto_()->add_members(v1::STRATEGY_PRBS);
  ASSERT_TRUE(ValidateSessionConfig(&c).ok());
  EXPECT_THAT(c.auto_().members(),
              ::testing::ElementsAre(v1::STRATEGY_MI, v1::STRATEGY_PRBS));
  EXPECT_EQ(c.signal().prbs_min_hold(), 5);
  EXPECT_FALSE(c.has_optimistic());
}

TEST(StrategyConfigTest, AutoPortfolioFillsItsMembersAndKeepsTheGpExact) {
  v1::SessionConfig c = Config(v1::STRATEGY_AUTO);  // the default chooser
  ASSERT_TRUE(ValidateSessionConfig(&c).ok());
  EXPECT_EQ(c.auto_().chooser(), v1::AutoConfig::CHOOSER_PORTFOLIO);  // filled in
  EXPECT_THAT(c.auto_().members(),
              ::testing::ElementsAre(v1::STRATEGY_REC, v1::STRATEGY_MI));
  // Its criterion is roi's objective: roi's block is filled in, the GP stays exact.
  EXPECT_EQ(c.roi().reference_points(), 256);
  EXPECT_EQ(c.sparse().above_samples(), 0);
  plan::PlanOptions o = PlanOptionsFromConfig(c);
  EXPECT_EQ(o.auto_chooser, plan::AutoChooser::kPortfolio);
  EXPECT_EQ(o.auto_members,
            (std::vector<plan::Strategy>{plan::Strategy::kRec, plan::Strategy::kMi}));
  EXPECT_TRUE(o.Validate(2, 1).ok());

  // Named members without a joint-covariance need still keep the GP exact, for the
  // criterion (mi's without state bounds).
  c = Config(v1::STRATEGY_AUTO);
  c.clear_state_bounds();
  c.mutable_auto_()->set_chooser(v1::AutoConfig::CHOOSER_PORTFOLIO);
  c.mutable_auto_()->add_members(v1::STRATEGY_REC);
  c.mutable_auto_()->add_members(v1::STRATEGY_PRBS);
  ASSERT_TRUE(ValidateSessionConfig(&c).ok());
  EXPECT_EQ(c.sparse().above_samples(), 0);
  EXPECT_FALSE(c.has_roi());
  c.mutable_sparse()->set_above_samples(500);
  ExpectInvalid(c, "config.sparse.above_samples");

  c = Config(v1::STRATEGY_AUTO);
  c.mutable_auto_()->set_chooser(static_cast<v1::AutoConfig::Chooser>(7));
  ExpectInvalid(c, "config.auto.chooser",
                "unknown value 7; valid: CHOOSER_BANDIT, CHOOSER_PORTFOLIO");
}

TEST(StrategyConfigTest, AutoRefusesMembersItCannotUse) {
  for (v1::Strategy bad : {v1::STRATEGY_PA, v1::STRATEGY_SEP, v1::STRATEGY_AUTO}) {
    v1::SessionConfig c = Config(v1::STRATEGY_AUTO);
    c.mutable_auto_()->add_members(v1::STRATEGY_REC);
    c.mutable_auto_()->add_members(bad);
    ExpectInvalid(c, "config.auto.members[1]", "cannot be a member of STRATEGY_AUTO");
  }
  v1::SessionConfig c = Config(v1::STRATEGY_AUTO);
  c.mutable_auto_()->add_members(v1::STRATEGY_REC);
  c.mutable_auto_()->add_members(v1::STRATEGY_REC);
  ExpectInvalid(c, "config.auto.members[1]", "STRATEGY_REC is named twice");
  c = Config(v1::STRATEGY_AUTO);
  c.mutable_auto_()->add_members(static_cast<v1::Strategy>(99));
  ExpectInvalid(c, "config.auto.members[0]", "unknown strategy 99; valid: ");
  c = Config(v1::STRATEGY_AUTO);
  c.clear_state_bounds();
  c.mutable_auto_()->add_members(v1::STRATEGY_ROI);
  ExpectInvalid(c, "config.state_bounds",
                "STRATEGY_ROI (a member of STRATEGY_AUTO) needs state_dim (2)");
}

TEST(StrategyConfigTest, DimensionNamesAndUnits) {
  v1::SessionConfig c = Config(v1::STRATEGY_REC);
  c.add_state_names("theta");
  c.add_state_names("theta_dot");
  c.add_state_units("rad");
  c.add_state_units("rad/s");
  c.add_input_names("tau");
  ASSERT_TRUE(ValidateSessionConfig(&c).ok());
  v1::SessionConfig bad = c;
  bad.add_input_names("extra");
  ExpectInvalid(bad, "config.input_names", "one entry per dimension (1), got 2");
  bad = c;
  bad.set_input_names(0, "theta");
  ExpectInvalid(bad, "config.input_names[0]", "\"theta\" names two dimensions");
  bad = c;
  bad.set_state_names(1, "2nd");
  ExpectInvalid(bad, "config.state_names[1]", "starting with a letter");
  bad = c;
  bad.set_state_names(1, std::string(33, 'a'));
  ExpectInvalid(bad, "config.state_names[1]", "1-32 letters");
  bad = c;
  bad.set_state_units(0, "radians per tick!!");  // 18 characters
  ExpectInvalid(bad, "config.state_units[0]", "at most 16 printable");
  bad = c;
  bad.set_state_units(0, "r\nad");
  ExpectInvalid(bad, "config.state_units[0]", "printable");
}

TEST(StrategyConfigTest, SafeBox) {
  v1::SessionConfig c = Config(v1::STRATEGY_REC);
  ASSERT_TRUE(ValidateSessionConfig(&c).ok());
  EXPECT_FALSE(c.has_safety());
  EXPECT_FALSE(PlanOptionsFromConfig(c).safe_box.active());

  c = Config(v1::STRATEGY_REC);
  v1::Interval* theta = c.mutable_safety()->add_state_bounds();
  theta->set_lower(-1.0);
  theta->set_upper(1.0);
  v1::Interval* omega = c.mutable_safety()->add_state_bounds();
  omega->set_lower(-4.0);
  omega->set_upper(5.0);
  ASSERT_TRUE(ValidateSessionConfig(&c).ok());
  EXPECT_EQ(c.safety().margin(), 2.0);  // the default is filled in
  plan::PlanOptions o = PlanOptionsFromConfig(c);
  ASSERT_TRUE(o.safe_box.active());
  EXPECT_EQ(o.safe_box.lower(1), -4.0);
  EXPECT_EQ(o.safe_box.upper(1), 5.0);
  EXPECT_EQ(o.safe_box.margin, 2.0);
  // An explicit 0 margin is kept (proto3 optional).
  c.mutable_safety()->set_margin(0.0);
  ASSERT_TRUE(ValidateSessionConfig(&c).ok());
  EXPECT_EQ(PlanOptionsFromConfig(c).safe_box.margin, 0.0);

  v1::SessionConfig bad = c;
  bad.mutable_safety()->set_margin(11.0);
  ExpectInvalid(bad, "config.safety.margin", "[0, 10]");
  bad = c;
  bad.mutable_safety()->set_margin(std::nan(""));
  ExpectInvalid(bad, "config.safety.margin");
  bad = c;
  bad.mutable_safety()->mutable_state_bounds(1)->set_upper(-5.0);
  ExpectInvalid(bad, "config.safety.state_bounds[1]");
  bad = c;
  bad.mutable_safety()->mutable_state_bounds()->RemoveLast();
  ExpectInvalid(bad, "config.safety.state_bounds", "0 or state_dim (2)");
}

}  // namespace
}  // namespace excite::service
