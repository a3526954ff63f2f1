#include "sim/plants/plant_factory.h"

#include <gtest/gtest.h>

#include "absl/status/status.h"
#include "sim/plants/pendulum.h"

namespace excite::sim {
namespace {

v1::PlantConfig ValidPendulumConfig() {
  v1::PlantConfig config;
  config.set_dt_s(0.1);
  config.set_substeps(10);
  config.add_initial_state(0.0);
  config.add_initial_state(0.0);
  v1::PendulumParams* p = config.mutable_pendulum();
  p->set_mass_kg(1.0);
  p->set_length_m(1.0);
  p->set_damping(0.1);
  p->set_gravity(9.81);
  return config;
}

TEST(PlantFactoryTest, BuildsPendulum) {
  absl::StatusOr<std::unique_ptr<Plant>> plant = MakePlant(ValidPendulumConfig());
  ASSERT_TRUE(plant.ok()) << plant.status();
  EXPECT_EQ((*plant)->name(), "pendulum");
  const auto* pendulum = dynamic_cast<const Pendulum*>(plant->get());
  ASSERT_NE(pendulum, nullptr);
  EXPECT_EQ(pendulum->dt_s(), 0.1);
  EXPECT_EQ(pendulum->substeps(), 10);
  EXPECT_EQ(pendulum->parameters().gravity, 9.81);
}

TEST(PlantFactoryTest, ZeroDampingIsAllowed) {
  v1::PlantConfig config = ValidPendulumConfig();
  config.mutable_pendulum()->set_damping(0.0);
  EXPECT_TRUE(MakePlant(config).ok());
}

TEST(PlantFactoryTest, EmptyInitialStateIsAllowed) {
  v1::PlantConfig config = ValidPendulumConfig();
  config.clear_initial_state();
  EXPECT_TRUE(MakePlant(config).ok());
}

TEST(PlantFactoryTest, MissingModel) {
  v1::PlantConfig config = ValidPendulumConfig();
  config.clear_pendulum();
  absl::StatusOr<std::unique_ptr<Plant>> plant = MakePlant(config);
  EXPECT_EQ(plant.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(plant.status().message().find("model"), std::string::npos);
}

struct BadCase {
  const char* name;
  void (*mutate)(v1::PlantConfig*);
  const char* field;
};

class PlantFactoryErrorTest : public testing::TestWithParam<BadCase> {};

TEST_P(PlantFactoryErrorTest, InvalidArgumentNamingTheField) {
  v1::PlantConfig config = ValidPendulumConfig();
  GetParam().mutate(&config);
  absl::StatusOr<std::unique_ptr<Plant>> plant = MakePlant(config);
  EXPECT_EQ(plant.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(plant.status().message().find(GetParam().field), std::string::npos)
      << plant.status();
}

INSTANTIATE_TEST_SUITE_P(
    All, PlantFactoryErrorTest,
    testing::Values(
        BadCase{"ZeroDt", [](v1::PlantConfig* c) { c->set_dt_s(0.0); }, "dt_s"},
        BadCase{"NegativeDt", [](v1::PlantConfig* c) { c->set_dt_s(-0.1); }, "dt_s"},
        BadCase{"ZeroSubsteps", [](v1::PlantConfig* c) { c->set_substeps(0); },
                "substeps"},
        BadCase{"ZeroMass",
                [](v1::PlantConfig* c) { c->mutable_pendulum()->set_mass_kg(0); },
                "mass_kg"},
        BadCase{"NegativeLength",
                [](v1::PlantConfig* c) { c->mutable_pendulum()->set_length_m(-1); },
                "length_m"},
        BadCase{"ZeroGravity",
                [](v1::PlantConfig* c) { c->mutable_pendulum()->set_gravity(0); },
                "gravity"},
        BadCase{"NegativeDamping",
                [](v1::PlantConfig* c) { c->mutable_pendulum()->set_damping(-0.1); },
                "damping"},
        BadCase{"NanMass",
                [](v1::PlantConfig* c) { c->mutable_pendulum()->set_mass_kg(NAN); },
                "mass_kg"},
        BadCase{"WrongInitialStateSize",
                [](v1::PlantConfig* c) { c->add_initial_state(1.0); }, "initial_state"}),
    [](const testing::TestParamInfo<BadCase>& param_info) {
      return param_info.param.name;
    });

}  // namespace
}  // namespace excite::sim
