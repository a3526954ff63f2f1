#include "server/service/config_validation.h"

#include <cmath>
#include <fstream>
#include <limits>
#include <string>

#include "excite/v1/sim_config.pb.h"
#include "gmock/gmock.h"
#include "google/protobuf/text_format.h"
#include "gtest/gtest.h"
#include "server/service/config_text.h"
#include "tests/support/temp_dir.h"

namespace excite::service {
namespace {

using ::testing::HasSubstr;

constexpr char kPendulum[] = R"pb(
  state_dim: 2
  input_dim: 1
  input_bounds { lower: -5 upper: 5 }
  state_bounds { lower: -3.2 upper: 3.2 }
  state_bounds { lower: -8 upper: 8 }
  noise { variance: 0.05 fit: true }
  kernel { fit: true }
)pb";

v1::SessionConfig Valid() {
  absl::StatusOr<v1::SessionConfig> config = ParseSessionConfigText(kPendulum);
  EXPECT_TRUE(config.ok()) << config.status();
  return *config;
}

// Expects INVALID_ARGUMENT whose message starts with `field` and contains `what`.
void ExpectInvalid(v1::SessionConfig config, const std::string& field,
                   const std::string& what = "") {
  absl::Status status = ValidateSessionConfig(&config);
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument) << status;
  EXPECT_THAT(std::string(status.message()), ::testing::StartsWith(field + ":"))
      << status;
  EXPECT_THAT(std::string(status.message()), HasSubstr(what)) << status;
}

TEST(ConfigValidationTest, FillsDocumentedDefaults) {
  v1::SessionConfig config = Valid();
  ASSERT_TRUE(ValidateSessionConfig(&config).ok());
  EXPECT_EQ(config.target(), v1::TARGET_DELTA);
  EXPECT_EQ(config.strategy(), v1::STRATEGY_REC);
  EXPECT_EQ(config.horizon(), 15);
  EXPECT_EQ(config.kernel().lengthscale_bounds().lower(), 0.05);
  EXPECT_EQ(config.kernel().lengthscale_bounds().upper(), 50.0);
  EXPECT_EQ(config.kernel().signal_variance_bounds().lower(), 0.01);
  EXPECT_EQ(config.kernel().signal_variance_bounds().upper(), 100.0);
  EXPECT_EQ(config.kernel().restarts(), 2);
  EXPECT_EQ(config.kernel().max_iterations(), 60);
  EXPECT_EQ(config.refit().every_samples(), 1);
  EXPECT_EQ(config.refit().growth(), 0.05);
  EXPECT_EQ(config.refit().min_samples(), 2);
  EXPECT_FALSE(config.refit().never());
  EXPECT_EQ(config.planner().max_iterations(), 100);
  EXPECT_EQ(config.planner().restarts(), 1);
  EXPECT_EQ(config.planner().tolerance(), 1e-4);
  EXPECT_EQ(config.planner().time_budget_s(), 10.0);
  EXPECT_EQ(config.sparse().above_samples(), 1000);
  EXPECT_EQ(config.sparse().max_inducing(), 256);
  EXPECT_EQ(config.sparse().inducing_tolerance(), 0.1);
  EXPECT_EQ(config.sparse().fit_samples(), 1000);
  // Idempotent: a validated config validates to itself.
  v1::SessionConfig again = config;
  ASSERT_TRUE(ValidateSessionConfig(&again).ok());
  EXPECT_EQ(again.SerializeAsString(), config.SerializeAsString());
}

TEST(ConfigValidationTest, KeepsExplicitValues) {
  v1::SessionConfig config = Valid();
  config.set_horizon(7);
  config.set_strategy(v1::STRATEGY_PA);
  config.set_target(v1::TARGET_NEXT);
  config.mutable_planner()->set_time_budget_s(0.5);
  config.mutable_refit()->set_every_samples(5);
  config.mutable_refit()->set_growth(0.0);  // set, so not the default
  config.mutable_refit()->set_min_samples(10);
  ASSERT_TRUE(ValidateSessionConfig(&config).ok());
  EXPECT_EQ(config.horizon(), 7);
  EXPECT_EQ(config.strategy(), v1::STRATEGY_PA);
  EXPECT_EQ(config.target(), v1::TARGET_NEXT);
  EXPECT_EQ(config.planner().time_budget_s(), 0.5);
  EXPECT_EQ(config.refit().every_samples(), 5);
  EXPECT_EQ(config.refit().growth(), 0.0);
  EXPECT_EQ(config.refit().min_samples(), 10);
}

TEST(ConfigValidationTest, GreedyForcesHorizonOne) {
  v1::SessionConfig config = Valid();
  config.set_strategy(v1::STRATEGY_GREEDY);
  config.set_horizon(15);
  ASSERT_TRUE(ValidateSessionConfig(&config).ok());
  EXPECT_EQ(config.horizon(), 1);
}

TEST(ConfigValidationTest, Dimensions) {
  v1::SessionConfig c = Valid();
  c.set_state_dim(0);
  ExpectInvalid(c, "config.state_dim", "[1, 64]");
  c = Valid();
  c.set_state_dim(65);
  ExpectInvalid(c, "config.state_dim");
  c = Valid();
  c.set_input_dim(0);
  ExpectInvalid(c, "config.input_dim", "[1, 32]");
  c = Valid();
  c.set_input_dim(33);
  ExpectInvalid(c, "config.input_dim");
}

TEST(ConfigValidationTest, InputBounds) {
  v1::SessionConfig c = Valid();
  c.add_input_bounds()->set_upper(1);
  ExpectInvalid(c, "config.input_bounds", "must have input_dim (1) entries, got 2");
  c = Valid();
  c.clear_input_bounds();
  ExpectInvalid(c, "config.input_bounds", "got 0");
  c = Valid();
  c.mutable_input_bounds(0)->set_lower(2);
  c.mutable_input_bounds(0)->set_upper(1);
  ExpectInvalid(c, "config.input_bounds[0]", "lower (2) must be < upper (1)");
  c = Valid();
  c.mutable_input_bounds(0)->set_upper(-5);
  ExpectInvalid(c, "config.input_bounds[0]", "must be < upper");
  c = Valid();
  c.mutable_input_bounds(0)->set_upper(std::numeric_limits<double>::infinity());
  ExpectInvalid(c, "config.input_bounds[0]", "finite");
  c = Valid();
  c.mutable_input_bounds(0)->set_lower(std::nan(""));
  ExpectInvalid(c, "config.input_bounds[0]", "finite");
}

TEST(ConfigValidationTest, StateBounds) {
  v1::SessionConfig c = Valid();
  c.clear_state_bounds();
  EXPECT_TRUE(ValidateSessionConfig(&c).ok());  // 0 entries are allowed
  c = Valid();
  c.mutable_state_bounds()->RemoveLast();
  ExpectInvalid(c, "config.state_bounds", "0 or state_dim (2) entries, got 1");
  c = Valid();
  c.mutable_state_bounds(1)->set_lower(8);
  ExpectInvalid(c, "config.state_bounds[1]", "lower (8) must be < upper (8)");
  // Intervals normalise the model's inputs: within +-1e30, at least 1e-30 wide.
  c = Valid();
  c.mutable_state_bounds(0)->set_lower(-1e308);
  ExpectInvalid(c, "config.state_bounds[0]", "must be within +-1e+30");
  c = Valid();
  c.mutable_state_bounds(0)->set_lower(1e-300);
  c.mutable_state_bounds(0)->set_upper(2e-300);
  ExpectInvalid(c, "config.state_bounds[0]", "upper - lower must be >= 1e-30");
  c = Valid();
  c.mutable_input_bounds(0)->set_upper(1e31);
  ExpectInvalid(c, "config.input_bounds[0]", "must be within +-1e+30");
}

TEST(ConfigValidationTest, Noise) {
  v1::SessionConfig c = Valid();
  c.clear_noise();
  ExpectInvalid(c, "config.noise.variance", "must be in [1e-30, 1e+30], got 0");
  c = Valid();
  c.mutable_noise()->set_variance(-1);
  ExpectInvalid(c, "config.noise.variance");
  c = Valid();
  c.mutable_noise()->set_variance(std::numeric_limits<double>::infinity());
  ExpectInvalid(c, "config.noise.variance");
}

v1::SessionConfig FixedKernel() {
  v1::SessionConfig c = Valid();
  c.mutable_noise()->set_fit(false);
  c.mutable_kernel()->set_fit(false);
  for (int i = 0; i < 2; ++i) {
    v1::Hyperparameters* h = c.mutable_kernel()->add_fixed();
    h->set_signal_variance(1.0);
    for (int l = 0; l < 3; ++l) h->add_lengthscales(1.0);
    h->set_noise_variance(0.1);
  }
  return c;
}

TEST(ConfigValidationTest, FixedKernel) {
  v1::SessionConfig c = FixedKernel();
  EXPECT_TRUE(ValidateSessionConfig(&c).ok());
  c = FixedKernel();
  c.mutable_kernel()->mutable_fixed()->RemoveLast();
  ExpectInvalid(c, "config.kernel.fixed",
                "state_dim (2) entries when kernel.fit is false");
  c = FixedKernel();
  c.mutable_kernel()->mutable_fixed(1)->set_signal_variance(0);
  ExpectInvalid(c, "config.kernel.fixed[1].signal_variance", "[1e-100, 1e+100]");
  c = FixedKernel();
  c.mutable_kernel()->mutable_fixed(0)->add_lengthscales(1.0);
  ExpectInvalid(c, "config.kernel.fixed[0].lengthscales", "(3) entries, got 4");
  c = FixedKernel();
  c.mutable_kernel()->mutable_fixed(0)->set_lengthscales(2, -1.0);
  ExpectInvalid(c, "config.kernel.fixed[0].lengthscales[2]", "[1e-50, 1e+50]");
  // The issue's configs that could never work: finite, positive, but absurd.
  c = FixedKernel();
  c.mutable_kernel()->mutable_fixed(0)->set_signal_variance(1.7e308);
  ExpectInvalid(c, "config.kernel.fixed[0].signal_variance", "got 1.7e+308");
  c = FixedKernel();
  c.mutable_kernel()->mutable_fixed(0)->set_lengthscales(0, 5e-324);
  ExpectInvalid(c, "config.kernel.fixed[0].lengthscales[0]", "[1e-50, 1e+50]");
  c = FixedKernel();
  c.mutable_kernel()->mutable_fixed(0)->set_lengthscales(0, 1e-50);
  c.mutable_kernel()->mutable_fixed(0)->set_signal_variance(1e100);
  c.mutable_kernel()->mutable_fixed(0)->set_noise_variance(1e-100);
  EXPECT_TRUE(ValidateSessionConfig(&c).ok());  // the corners are allowed
  c = FixedKernel();
  c.mutable_kernel()->mutable_fixed(0)->set_noise_variance(std::nan(""));
  ExpectInvalid(c, "config.kernel.fixed[0].noise_variance");
  c = FixedKernel();
  c.mutable_noise()->set_fit(true);
  ExpectInvalid(c, "config.noise.fit", "kernel.fit is true");
  c = FixedKernel();
  c.mutable_kernel()->set_fit(true);
  ExpectInvalid(c, "config.kernel.fixed", "must be empty when kernel.fit is true");
}

// angle_dims: state dimensions, each once, with the delta target; an angle adds
// a lengthscale (its sine and cosine) and cannot be held by a safe box.
TEST(ConfigValidationTest, Angles) {
  v1::SessionConfig c = Valid();
  c.add_angle_dims(0);
  EXPECT_TRUE(ValidateSessionConfig(&c).ok());
  EXPECT_EQ(KernelInputs(c), 4);
  v1::SessionConfig bad = c;
  bad.add_angle_dims(2);
  ExpectInvalid(bad, "config.angle_dims[1]", "state dimension in [0, 2), got 2");
  bad = c;
  bad.add_angle_dims(0);
  ExpectInvalid(bad, "config.angle_dims[1]", "names state 0 twice");
  bad = c;
  bad.set_target(v1::TARGET_NEXT);
  ExpectInvalid(bad, "config.target", "angle_dims need TARGET_DELTA");

  v1::SessionConfig fixed = FixedKernel();
  fixed.add_angle_dims(0);
  ExpectInvalid(fixed, "config.kernel.fixed[0].lengthscales",
                "one per angle (4) entries, got 3");
  for (int i = 0; i < 2; ++i)
    fixed.mutable_kernel()->mutable_fixed(i)->add_lengthscales(1);
  EXPECT_TRUE(ValidateSessionConfig(&fixed).ok());

  v1::SessionConfig safe = c;
  v1::SafetyConfig* safety = safe.mutable_safety();
  v1::Interval* angle = safety->add_state_bounds();
  angle->set_lower(-1.0);
  angle->set_upper(1.0);
  v1::Interval* rate = safety->add_state_bounds();
  rate->set_lower(-5.0);
  rate->set_upper(5.0);
  ExpectInvalid(safe, "config.safety.state_bounds[0]", "narrower than one turn");
  angle->set_lower(-3.2);
  angle->set_upper(3.2);
  EXPECT_TRUE(ValidateSessionConfig(&safe).ok());
}

// kernel.fit unset: fitted when no fixed hyperparameters are given (a minimal
// config works), fixed when they are; the filled-in value is explicit.
TEST(ConfigValidationTest, UnsetKernelFitDependsOnFixed) {
  v1::SessionConfig minimal;
  ASSERT_TRUE(google::protobuf::TextFormat::ParseFromString(
      R"pb(state_dim: 4
           input_dim: 1
           input_bounds { lower: -1 upper: 1 }
           noise { variance: 0.01 })pb",
      &minimal));
  ASSERT_FALSE(minimal.kernel().has_fit());
  ASSERT_TRUE(ValidateSessionConfig(&minimal).ok());
  EXPECT_TRUE(minimal.kernel().has_fit());
  EXPECT_TRUE(minimal.kernel().fit());
  v1::SessionConfig fixed = FixedKernel();
  fixed.mutable_kernel()->clear_fit();
  ASSERT_TRUE(ValidateSessionConfig(&fixed).ok());
  EXPECT_TRUE(fixed.kernel().has_fit());
  EXPECT_FALSE(fixed.kernel().fit());
}

TEST(ConfigValidationTest, FitBoundsAndCounts) {
  v1::SessionConfig c = Valid();
  c.mutable_kernel()->mutable_lengthscale_bounds()->set_lower(0);
  c.mutable_kernel()->mutable_lengthscale_bounds()->set_upper(10);
  ExpectInvalid(c, "config.kernel.lengthscale_bounds",
                "within [1e-06, 1e+06], got [0, 10]");
  c = Valid();
  c.mutable_kernel()->mutable_signal_variance_bounds()->set_lower(1e-3);
  c.mutable_kernel()->mutable_signal_variance_bounds()->set_upper(1e300);
  ExpectInvalid(c, "config.kernel.signal_variance_bounds", "within [1e-12, 1e+12]");
  c = Valid();
  c.mutable_kernel()->mutable_signal_variance_bounds()->set_lower(5);
  c.mutable_kernel()->mutable_signal_variance_bounds()->set_upper(1);
  ExpectInvalid(c, "config.kernel.signal_variance_bounds",
                "lower (5) must be < upper (1)");
  c = Valid();
  c.mutable_kernel()->set_restarts(-1);
  ExpectInvalid(c, "config.kernel.restarts", "[0, 20]");
  c = Valid();
  c.mutable_kernel()->set_restarts(100);  // 25 s of refit at 400 samples
  ExpectInvalid(c, "config.kernel.restarts", "[0, 20]");
  c = Valid();
  c.mutable_kernel()->set_max_iterations(-3);
  ExpectInvalid(c, "config.kernel.max_iterations");
  c = Valid();
  c.mutable_kernel()->set_max_iterations(10000);
  ExpectInvalid(c, "config.kernel.max_iterations", "[1, 1000]");
}

TEST(ConfigValidationTest, EnumsAndHorizon) {
  v1::SessionConfig c = Valid();
  c.set_target(static_cast<v1::Target>(9));
  ExpectInvalid(c, "config.target", "unknown value 9");
  c = Valid();
  c.set_strategy(static_cast<v1::Strategy>(42));
  ExpectInvalid(c, "config.strategy", "unknown value 42");
  c = Valid();
  c.set_horizon(201);
  ExpectInvalid(c, "config.horizon", "[1, 200]");
  c = Valid();
  c.set_horizon(-1);
  ExpectInvalid(c, "config.horizon");
}

TEST(ConfigValidationTest, RefitAndPlanner) {
  v1::SessionConfig c = Valid();
  c.mutable_refit()->set_every_samples(-1);
  ExpectInvalid(c, "config.refit.every_samples");
  for (double growth : {-0.01, 10.5, std::nan("")}) {
    c = Valid();
    c.mutable_refit()->set_growth(growth);
    ExpectInvalid(c, "config.refit.growth", "[0, 10]");
  }
  c = Valid();
  c.mutable_refit()->set_min_samples(1);
  ExpectInvalid(c, "config.refit.min_samples", "[2, 1000000]");
  c = Valid();
  c.mutable_planner()->set_max_iterations(-1);
  ExpectInvalid(c, "config.planner.max_iterations");
  c = Valid();
  c.mutable_planner()->set_restarts(101);
  ExpectInvalid(c, "config.planner.restarts");
  c = Valid();
  c.mutable_planner()->set_tolerance(1.5);
  ExpectInvalid(c, "config.planner.tolerance", "(0, 1)");
  c = Valid();
  c.mutable_planner()->set_time_budget_s(-2);
  ExpectInvalid(c, "config.planner.time_budget_s");
  c = Valid();
  c.mutable_planner()->set_time_budget_s(1e-300);  // no solve returns in that
  ExpectInvalid(c, "config.planner.time_budget_s", "[0.001, 3600]");
  c = Valid();
  c.mutable_planner()->set_time_budget_s(std::nan(""));
  ExpectInvalid(c, "config.planner.time_budget_s");
}

TEST(ConfigValidationTest, Sparse) {
  // 0: never sparse; the other two are then left unset.
  v1::SessionConfig c = Valid();
  c.mutable_sparse()->set_above_samples(0);
  ASSERT_TRUE(ValidateSessionConfig(&c).ok());
  EXPECT_TRUE(c.sparse().has_above_samples());
  EXPECT_EQ(c.sparse().above_samples(), 0);
  EXPECT_EQ(c.sparse().max_inducing(), 0);
  // MI and ROI need joint covariances: exact by default, and only exact.
  for (v1::Strategy joint : {v1::STRATEGY_MI, v1::STRATEGY_ROI}) {
    c = Valid();
    c.set_strategy(joint);
    ASSERT_TRUE(ValidateSessionConfig(&c).ok());
    EXPECT_EQ(c.sparse().above_samples(), 0);
    c = Valid();
    c.set_strategy(joint);
    c.mutable_sparse()->set_above_samples(500);
    ExpectInvalid(c, "config.sparse.above_samples", "joint covariances");
  }
  for (int above : {-1, 9, 1000001}) {
    c = Valid();
    c.mutable_sparse()->set_above_samples(above);
    ExpectInvalid(c, "config.sparse.above_samples", "[10, 1000000]");
  }
  for (int inducing : {-1, 4097}) {
    c = Valid();
    c.mutable_sparse()->set_max_inducing(inducing);
    ExpectInvalid(c, "config.sparse.max_inducing", "[1, 4096]");
  }
  for (int fit_samples : {-1, 9, 100001}) {
    c = Valid();
    c.mutable_sparse()->set_fit_samples(fit_samples);
    ExpectInvalid(c, "config.sparse.fit_samples", "[10, 100000]");
  }
  for (double tolerance : {-0.1, 1e-7, 2e6, std::nan("")}) {
    c = Valid();
    c.mutable_sparse()->set_inducing_tolerance(tolerance);
    ExpectInvalid(c, "config.sparse.inducing_tolerance", "[1e-6, 1e6]");
  }
  c = Valid();
  c.mutable_sparse()->set_above_samples(1000);
  c.mutable_sparse()->set_max_inducing(64);
  c.mutable_sparse()->set_inducing_tolerance(0.01);
  c.mutable_sparse()->set_fit_samples(500);
  ASSERT_TRUE(ValidateSessionConfig(&c).ok());
  EXPECT_EQ(c.sparse().fit_samples(), 500);
  EXPECT_EQ(c.sparse().above_samples(), 1000);
  EXPECT_EQ(c.sparse().max_inducing(), 64);
  EXPECT_EQ(c.sparse().inducing_tolerance(), 0.01);
}

TEST(ConfigValidationTest, PathPrefixForConfigFiles) {
  v1::SessionConfig c = Valid();
  c.set_state_dim(0);
  absl::Status status = ValidateSessionConfig(&c, "session");
  EXPECT_THAT(std::string(status.message()), ::testing::StartsWith("session.state_dim:"));
}

TEST(ConfigTextTest, ParseErrorsNameLineAndColumn) {
  absl::StatusOr<v1::SessionConfig> config =
      ParseSessionConfigText("state_dim: 2\nbogus: 1\n");
  EXPECT_EQ(config.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(config.status().message()), HasSubstr("2:"));
  EXPECT_THAT(std::string(config.status().message()), HasSubstr("bogus"));
  EXPECT_EQ(LoadSessionConfigFile("/nonexistent/x.textproto").status().code(),
            absl::StatusCode::kNotFound);
}

TEST(ConfigTextTest, UnknownEnumValuesListTheValidOnes) {
  absl::StatusOr<v1::SessionConfig> config =
      ParseSessionConfigText("state_dim: 2\nstrategy: STRATEGY_BOGUS\n");
  EXPECT_THAT(std::string(config.status().message()),
              HasSubstr("\"STRATEGY_BOGUS\" for field \"strategy\". Valid: rec, pa, "));
  EXPECT_THAT(std::string(config.status().message()),
              HasSubstr("auto (any case, with or without STRATEGY_)."));
}

// As everywhere else, an enum value may be written by its short name in any
// case, in plain fields, lists and nested messages; nothing else changes.
TEST(ConfigTextTest, EnumValuesMayBeShortNamesInAnyCase) {
  absl::StatusOr<v1::SessionConfig> config = ParseSessionConfigText(
      "state_dim: 2  # strategy: nope\n"
      "\tstrategy:auto target: Next\n"
      "name_of_nothing_else: 1\n");
  EXPECT_THAT(std::string(config.status().message()), HasSubstr("3:"));  // still an error
  config = ParseSessionConfigText(
      "state_dim: 2  # strategy: nope\n"
      "\tstrategy:auto target: Next\n"
      "auto { members: [Rec, STRATEGY_random, strategy_ROI] }\n"
      "sep { }  roi { reference_points: 9 }\n");
  ASSERT_TRUE(config.ok()) << config.status();
  EXPECT_EQ(config->strategy(), v1::STRATEGY_AUTO);
  EXPECT_EQ(config->target(), v1::TARGET_NEXT);
  ASSERT_EQ(config->auto_().members_size(), 3);
  EXPECT_EQ(config->auto_().members(0), v1::STRATEGY_REC);
  EXPECT_EQ(config->auto_().members(1), v1::STRATEGY_RANDOM);
  EXPECT_EQ(config->auto_().members(2), v1::STRATEGY_ROI);
  // A plant's file too (the session nested in a SimConfig).
  v1::SimConfig sim;
  ASSERT_TRUE(
      ParseTextProto("system: \"x\" session { strategy: optimistic }", &sim).ok());
  EXPECT_EQ(sim.session().strategy(), v1::STRATEGY_OPTIMISTIC);
  // Strings are not touched.
  ASSERT_TRUE(ParseTextProto("system: \"rec\"", &sim).ok());
  EXPECT_EQ(sim.system(), "rec");
}

TEST(ConfigTextTest, AConfigFileMayBeAPlantsSimConfig) {
  excite::testing::TempDir tmp;
  const std::string sim = tmp.path() + "/sim.textproto";
  std::ofstream(sim) << "system: \"pendulum\"\nsession { state_dim: 2 input_dim: 1 }\n";
  absl::StatusOr<v1::SessionConfig> config = LoadSessionConfigFile(sim);
  ASSERT_TRUE(config.ok()) << config.status();
  EXPECT_EQ(config->state_dim(), 2);
  // A mistake in either kind is said in that kind's terms only.
  std::ofstream(sim) << "system: \"pendulum\"\nsession { target: TARGET_X }\n";
  config = LoadSessionConfigFile(sim);
  EXPECT_THAT(std::string(config.status().message()),
              ::testing::AllOf(HasSubstr("SimConfig text format: 2:"),
                               HasSubstr("Valid: delta, next"),
                               ::testing::Not(HasSubstr("SessionConfig"))));
  const std::string session = tmp.path() + "/session.textproto";
  std::ofstream(session) << "state_dim: 2\nhorizon: many\n";
  config = LoadSessionConfigFile(session);
  EXPECT_THAT(std::string(config.status().message()),
              ::testing::AllOf(HasSubstr("SessionConfig text format: 2:"),
                               ::testing::Not(HasSubstr("SimConfig"))));
}

}  // namespace
}  // namespace excite::service
