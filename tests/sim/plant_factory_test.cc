#include "sim/plants/plant_factory.h"

#include <gtest/gtest.h>

#include <cmath>
#include <tuple>

#include "absl/status/status.h"
#include "sim/plants/mujoco_plant.h"
#include "sim/plants/pendulum.h"
#include "sim/plants/two_link_arm.h"

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

TEST(PlantFactoryTest, BuildsEveryBenchmarkModel) {
  v1::PlantConfig two_link;
  two_link.set_dt_s(0.1);
  two_link.set_substeps(20);
  v1::TwoLinkParams* t = two_link.mutable_two_link();
  t->set_mass1_kg(1);
  t->set_mass2_kg(2);
  t->set_length1_m(1);
  t->set_length2_m(0.5);
  t->set_gravity(9.81);
  absl::StatusOr<std::unique_ptr<Plant>> plant = MakePlant(two_link);
  ASSERT_TRUE(plant.ok()) << plant.status();
  EXPECT_EQ((*plant)->name(), "two_link");
  EXPECT_EQ(dynamic_cast<const TwoLinkArm&>(**plant).parameters().mass2_kg, 2.0);

  v1::PlantConfig unicycle;
  unicycle.set_dt_s(0.1);
  unicycle.set_substeps(10);
  v1::UnicycleParams* u = unicycle.mutable_unicycle();
  u->set_mass_kg(1);
  u->set_yaw_inertia(0.05);
  u->set_half_track_m(0.2);
  u->set_lateral_damping(4);
  plant = MakePlant(unicycle);
  ASSERT_TRUE(plant.ok()) << plant.status();
  EXPECT_EQ((*plant)->state_dim(), 6);

  for (auto [model, state_dim, input_dim] :
       {std::tuple{"dipc", 8, 1}, std::tuple{"half_cheetah", 18, 6}}) {
    v1::PlantConfig mujoco;
    mujoco.set_dt_s(0.05);
    mujoco.set_substeps(5);
    mujoco.mutable_mujoco()->set_model(model);
    plant = MakePlant(mujoco);
    ASSERT_TRUE(plant.ok()) << plant.status();
    EXPECT_EQ((*plant)->name(), model);
    EXPECT_EQ((*plant)->state_dim(), state_dim);
    EXPECT_EQ((*plant)->input_dim(), input_dim);
    EXPECT_DOUBLE_EQ(dynamic_cast<const MujocoPlant&>(**plant).model().opt.timestep,
                     0.01);
  }
}

TEST(PlantFactoryTest, NewModelErrorsNameTheField) {
  v1::PlantConfig config;
  config.set_dt_s(0.1);
  config.set_substeps(1);
  config.mutable_mujoco()->set_model("cartpole");
  absl::StatusOr<std::unique_ptr<Plant>> plant = MakePlant(config);
  EXPECT_EQ(plant.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(plant.status().message().find("mujoco.model"), std::string::npos);

  config.mutable_two_link()->set_mass1_kg(1);  // Other fields 0: not positive.
  plant = MakePlant(config);
  EXPECT_EQ(plant.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(plant.status().message().find("two_link.mass2_kg"), std::string::npos)
      << plant.status();
  v1::TwoLinkParams* t = config.mutable_two_link();
  t->set_mass2_kg(1);
  t->set_length1_m(1);
  t->set_length2_m(1);
  t->set_gravity(9.81);
  t->set_damping2(-1);
  plant = MakePlant(config);
  EXPECT_NE(plant.status().message().find("two_link.damping2"), std::string::npos)
      << plant.status();

  v1::UnicycleParams* u = config.mutable_unicycle();
  u->set_mass_kg(1);
  u->set_yaw_inertia(0.05);
  u->set_half_track_m(0.2);
  plant = MakePlant(config);  // lateral_damping 0: the no-slip limit is not allowed.
  EXPECT_NE(plant.status().message().find("unicycle.lateral_damping"), std::string::npos)
      << plant.status();
  u->set_lateral_damping(4);
  u->set_yaw_damping(NAN);
  plant = MakePlant(config);
  EXPECT_NE(plant.status().message().find("unicycle.yaw_damping"), std::string::npos)
      << plant.status();
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
