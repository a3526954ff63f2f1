#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <memory>
#include <random>
#include <thread>
#include <vector>

#include "absl/status/status.h"
#include "sim/plants/dipc.h"
#include "sim/plants/half_cheetah.h"
#include "sim/plants/models/embedded_models.h"
#include "sim/plants/mujoco_model.h"

namespace excite::sim {
namespace {

std::unique_ptr<Dipc> MakeDipc() {
  absl::StatusOr<std::unique_ptr<Dipc>> dipc = Dipc::Create(0.05, 5);
  EXPECT_TRUE(dipc.ok()) << dipc.status();
  return dipc.ok() ? *std::move(dipc) : nullptr;
}

std::unique_ptr<HalfCheetah> MakeCheetah() {
  absl::StatusOr<std::unique_ptr<HalfCheetah>> cheetah = HalfCheetah::Create(0.05, 5);
  EXPECT_TRUE(cheetah.ok()) << cheetah.status();
  return cheetah.ok() ? *std::move(cheetah) : nullptr;
}

// Random states near x0 and inputs in [-1, 1].
std::vector<std::pair<Eigen::VectorXd, Eigen::VectorXd>> RandomPairs(
    const Plant& plant, const Eigen::VectorXd& x0, double spread, int count) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  std::vector<std::pair<Eigen::VectorXd, Eigen::VectorXd>> pairs;
  for (int i = 0; i < count; ++i) {
    Eigen::VectorXd u(plant.input_dim());
    for (int j = 0; j < u.size(); ++j) u(j) = uniform(rng);
    Eigen::VectorXd x = x0;
    for (int j = 0; j < x.size(); ++j) x(j) += spread * uniform(rng);
    pairs.emplace_back(x, u);
  }
  return pairs;
}

TEST(MujocoModelTest, EmbeddedModelsArePresent) {
  EXPECT_NE(EmbeddedMjcf("dipc").find("<mujoco"), absl::string_view::npos);
  EXPECT_NE(EmbeddedMjcf("half_cheetah").find("<mujoco"), absl::string_view::npos);
  EXPECT_TRUE(EmbeddedMjcf("nope").empty());
}

TEST(MujocoModelTest, BadXmlIsInvalidArgumentWithMujocosMessage) {
  absl::StatusOr<MjModelPtr> model =
      LoadMjcfFromString("broken", "<mujoco><worldbody><body><geom type=\"nope\"/>");
  EXPECT_EQ(model.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(model.status().message().find("broken"), std::string::npos) << model.status();
  EXPECT_GT(model.status().message().size(), 40u) << model.status();
  EXPECT_EQ(LoadMjcfFromString("empty", "").status().code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(DipcTest, LoadsWithTheStatedShapeAndTiming) {
  std::unique_ptr<Dipc> dipc = MakeDipc();
  ASSERT_NE(dipc, nullptr);
  EXPECT_EQ(dipc->name(), "dipc");
  EXPECT_EQ(dipc->state_dim(), 8);
  EXPECT_EQ(dipc->input_dim(), 1);
  EXPECT_EQ(dipc->model().nq, 3);
  EXPECT_DOUBLE_EQ(dipc->model().opt.timestep, 0.01);
  EXPECT_DOUBLE_EQ(dipc->dt_s(), 0.05);
  EXPECT_EQ(dipc->model().opt.integrator, mjINT_RK4);
  EXPECT_DOUBLE_EQ(dipc->model().actuator_gear[0], 500.0);
  const Eigen::VectorXd next =
      dipc->Step(Dipc::StateOf(0, M_PI, 0, 0, 0, 0), Eigen::VectorXd::Ones(1));
  EXPECT_EQ(next.size(), 8);
}

TEST(DipcTest, HangingAtRestStaysAtRestWithoutInput) {
  std::unique_ptr<Dipc> dipc = MakeDipc();
  ASSERT_NE(dipc, nullptr);
  Eigen::VectorXd x = Dipc::StateOf(0.3, M_PI, 0, 0, 0, 0);
  const Eigen::VectorXd x0 = x;
  for (int k = 0; k < 100; ++k) x = dipc->Step(x, Eigen::VectorXd::Zero(1));
  EXPECT_LT((x - x0).cwiseAbs().maxCoeff(), 1e-9) << x.transpose();
}

TEST(DipcTest, UprightIsUnstable) {
  std::unique_ptr<Dipc> dipc = MakeDipc();
  ASSERT_NE(dipc, nullptr);
  Eigen::VectorXd x = Dipc::StateOf(0, 0.01, 0, 0, 0, 0);
  for (int k = 0; k < 60; ++k) x = dipc->Step(x, Eigen::VectorXd::Zero(1));
  EXPECT_LT(x(3), 0.0) << "pole 1 should have fallen below the horizontal";
}

TEST(DipcTest, PushingTheCartMovesItThatWayAndSinCosStayOnTheCircle) {
  std::unique_ptr<Dipc> dipc = MakeDipc();
  ASSERT_NE(dipc, nullptr);
  Eigen::VectorXd x = Dipc::StateOf(0, M_PI, 0, 0, 0, 0);
  x = dipc->Step(x, Eigen::VectorXd::Constant(1, 0.1));
  EXPECT_GT(x(0), 0.0);
  EXPECT_GT(x(5), 0.0);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  for (int k = 0; k < 200; ++k) {
    x = dipc->Step(x, Eigen::VectorXd::Constant(1, uniform(rng)));
    ASSERT_NEAR(x(1) * x(1) + x(3) * x(3), 1.0, 1e-12);
    ASSERT_NEAR(x(2) * x(2) + x(4) * x(4), 1.0, 1e-12);
    ASSERT_LE(std::abs(x(0)), 2.05) << "the rail has half-length 2";
  }
}

TEST(HalfCheetahTest, LoadsWithTheStatedShapeMassAndTiming) {
  std::unique_ptr<HalfCheetah> cheetah = MakeCheetah();
  ASSERT_NE(cheetah, nullptr);
  EXPECT_EQ(cheetah->name(), "half_cheetah");
  EXPECT_EQ(cheetah->state_dim(), 18);
  EXPECT_EQ(cheetah->input_dim(), 6);
  const mjModel& m = cheetah->model();
  EXPECT_EQ(m.nq, 9);
  EXPECT_EQ(m.nv, 9);
  double total_mass = 0.0;
  for (int b = 0; b < m.nbody; ++b) total_mass += m.body_mass[b];
  EXPECT_NEAR(total_mass, 14.0, 1e-9);
  EXPECT_DOUBLE_EQ(m.opt.timestep, 0.01);
  for (int g = 0; g < m.ngeom; ++g) {
    if (m.geom_type[g] == mjGEOM_CAPSULE) {
      EXPECT_DOUBLE_EQ(m.geom_size[3 * g], 0.046);
    }
  }
  for (int a = 0; a < m.nu; ++a) {
    EXPECT_EQ(m.actuator_ctrlrange[2 * a], -1.0);
    EXPECT_EQ(m.actuator_ctrlrange[2 * a + 1], 1.0);
  }
}

TEST(HalfCheetahTest, FallsOntoTheFloorAndStopsThere) {
  std::unique_ptr<HalfCheetah> cheetah = MakeCheetah();
  ASSERT_NE(cheetah, nullptr);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(18);
  x(1) = 0.5;  // Dropped from 0.5 m above the model's pose.
  double lowest = x(1);
  for (int k = 0; k < 200; ++k) {
    x = cheetah->Step(x, Eigen::VectorXd::Zero(6));
    lowest = std::min(lowest, x(1));
  }
  EXPECT_LT(std::abs(x(1)), 0.1) << "it should stand near the pose height";
  EXPECT_GT(lowest, -0.3) << "the floor should stop it";
  EXPECT_LT(x.tail(9).cwiseAbs().maxCoeff(), 1e-2) << "it should be at rest";
}

TEST(MujocoPlantTest, SteppingIsDeterministicWhateverCameBefore) {
  std::unique_ptr<HalfCheetah> cheetah = MakeCheetah();
  ASSERT_NE(cheetah, nullptr);
  const auto pairs = RandomPairs(*cheetah, Eigen::VectorXd::Zero(18), 0.2, 20);
  std::vector<Eigen::VectorXd> first;
  for (const auto& [x, u] : pairs) first.push_back(cheetah->Step(x, u));
  for (int i = static_cast<int>(pairs.size()) - 1; i >= 0; --i) {  // Other order.
    EXPECT_EQ(cheetah->Step(pairs[i].first, pairs[i].second), first[i]) << i;
  }
}

TEST(MujocoPlantTest, ConcurrentStepsEqualSequentialOnes) {
  std::unique_ptr<Dipc> dipc = MakeDipc();
  std::unique_ptr<HalfCheetah> cheetah = MakeCheetah();
  ASSERT_NE(dipc, nullptr);
  ASSERT_NE(cheetah, nullptr);
  for (const Plant* plant : {static_cast<const Plant*>(dipc.get()),
                             static_cast<const Plant*>(cheetah.get())}) {
    Eigen::VectorXd x0 = plant->state_dim() == 8 ? Dipc::StateOf(0, M_PI, 0, 0, 0, 0)
                                                 : Eigen::VectorXd::Zero(18);
    const auto pairs = RandomPairs(*plant, x0, 0.1, 200);
    std::vector<Eigen::VectorXd> sequential;
    for (const auto& [x, u] : pairs) sequential.push_back(plant->Step(x, u));
    std::vector<Eigen::VectorXd> a(pairs.size()), b(pairs.size());
    std::thread t1([&] {
      for (size_t i = 0; i < pairs.size(); ++i)
        a[i] = plant->Step(pairs[i].first, pairs[i].second);
    });
    std::thread t2([&] {
      for (size_t i = pairs.size(); i-- > 0;)
        b[i] = plant->Step(pairs[i].first, pairs[i].second);
    });
    t1.join();
    t2.join();
    for (size_t i = 0; i < pairs.size(); ++i) {
      ASSERT_EQ(a[i], sequential[i]) << plant->name() << " " << i;
      ASSERT_EQ(b[i], sequential[i]) << plant->name() << " " << i;
    }
  }
}

}  // namespace
}  // namespace excite::sim
