// The cores a cgroup's CPU quota allows, and the cores this process may use.

#include "server/session/machine_limits.h"

#include <thread>

#include "gtest/gtest.h"

namespace excite::session {
namespace {

TEST(MachineLimitsTest, CpuMaxQuotaIsRoundedUpToCores) {
  EXPECT_EQ(CoresFromCpuMax("200000 100000"), 2);
  EXPECT_EQ(CoresFromCpuMax("150000 100000\n"), 2);
  EXPECT_EQ(CoresFromCpuMax("50000 100000"), 1);
  EXPECT_EQ(CoresFromCpuMax("6400000 100000"), 64);
}

TEST(MachineLimitsTest, CpuMaxWithoutALimitOrUnparsableGivesNone) {
  EXPECT_EQ(CoresFromCpuMax("max 100000"), 0);
  EXPECT_EQ(CoresFromCpuMax(""), 0);
  EXPECT_EQ(CoresFromCpuMax("200000"), 0);
  EXPECT_EQ(CoresFromCpuMax("-1 100000"), 0);
  EXPECT_EQ(CoresFromCpuMax("200000 0"), 0);
  EXPECT_EQ(CoresFromCpuMax("two cores"), 0);
}

TEST(MachineLimitsTest, AvailableCoresIsAtLeastOneAndAtMostTheMachines) {
  const int cores = AvailableCores();
  EXPECT_GE(cores, 1);
  const unsigned machine = std::thread::hardware_concurrency();
  if (machine > 0) {
    EXPECT_LE(cores, static_cast<int>(machine));
  }
}

}  // namespace
}  // namespace excite::session
