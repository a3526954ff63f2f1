// The strategy table: one row per enum value, in its order, each row complete
// for the way it plans.

#include "server/plan/strategy.h"

#include <set>
#include <string>

#include "gtest/gtest.h"

namespace excite::plan {
namespace {

TEST(StrategyTableTest, EveryRowIsCompleteForItsMethod) {
  std::set<std::string> names;
  int index = 0;
  for (const StrategyInfo& info : Strategies()) {
    SCOPED_TRACE(std::string(info.name));
    EXPECT_EQ(static_cast<int>(info.strategy), index++);  // InfoOf indexes by enum
    EXPECT_EQ(&InfoOf(info.strategy), &info);
    EXPECT_EQ(FindStrategy(info.name), &info);
    EXPECT_TRUE(names.insert(std::string(info.name)).second) << "name twice";
    EXPECT_FALSE(info.summary.empty());
    EXPECT_EQ(info.make_signal != nullptr, info.method == PlanMethod::kSignal);
    EXPECT_EQ(info.make_objective != nullptr, info.method == PlanMethod::kTrajectory);
    EXPECT_EQ(info.objective_scaling > 0.0, info.method == PlanMethod::kTrajectory);
    EXPECT_EQ(IsModelFree(info.strategy), info.method == PlanMethod::kSignal);
    if (info.method == PlanMethod::kSignal) {
      EXPECT_TRUE(info.apply_all);  // a signal's next samples are all applied
    }
  }
  EXPECT_EQ(index, static_cast<int>(Strategy::kAuto) + 1);
  EXPECT_EQ(FindStrategy("REC"), nullptr);
  EXPECT_EQ(FindStrategy(""), nullptr);
  // What the rest of the server relies on.
  EXPECT_EQ(InfoOf(Strategy::kGreedy).fixed_horizon, 1);
  EXPECT_TRUE(InfoOf(Strategy::kPa).apply_all);
  EXPECT_FALSE(InfoOf(Strategy::kRec).apply_all);
  EXPECT_TRUE(InfoOf(Strategy::kSep).needs_state_bounds);
  EXPECT_TRUE(InfoOf(Strategy::kRoi).needs_state_bounds);
  EXPECT_TRUE(InfoOf(Strategy::kMi).needs_joint_covariances);
  EXPECT_TRUE(InfoOf(Strategy::kRoi).needs_joint_covariances);
  EXPECT_TRUE(InfoOf(Strategy::kOptimistic).optimistic_dynamics);
  EXPECT_EQ(InfoOf(Strategy::kAuto).method, PlanMethod::kMembers);
  EXPECT_FALSE(InfoOf(Strategy::kAuto).apply_all);
  // auto's members: the receding-horizon trajectory strategies and the signals.
  for (Strategy s : {Strategy::kPa, Strategy::kSep, Strategy::kAuto}) {
    EXPECT_FALSE(CanBeAutoMember(s)) << InfoOf(s).name;
  }
  for (Strategy s :
       {Strategy::kRec, Strategy::kGreedy, Strategy::kMi, Strategy::kRoi,
        Strategy::kOptimistic, Strategy::kPrbs, Strategy::kChirp, Strategy::kRandom}) {
    EXPECT_TRUE(CanBeAutoMember(s)) << InfoOf(s).name;
  }
}

}  // namespace
}  // namespace excite::plan
