#include "sim/input_schedule.h"

#include "gtest/gtest.h"

namespace excite::sim {
namespace {

Eigen::VectorXd U(double u) { return Eigen::VectorXd::Constant(1, u); }

Eigen::MatrixXd Rows(std::initializer_list<double> values) {
  Eigen::MatrixXd m(static_cast<Eigen::Index>(values.size()), 1);
  Eigen::Index i = 0;
  for (double v : values) m(i++, 0) = v;
  return m;
}

TEST(InputScheduleTest, HoldsTheFirstInputUntilAPlanArrives) {
  InputSchedule schedule(U(0.5));
  bool from_plan = true;
  EXPECT_EQ(schedule.Take(0, &from_plan)(0), 0.5);
  EXPECT_FALSE(from_plan);
  EXPECT_EQ(schedule.Take(1, &from_plan)(0), 0.5);
  EXPECT_FALSE(from_plan);
}

TEST(InputScheduleTest, AppliesPlanRowsByStepThenHoldsTheLast) {
  InputSchedule schedule(U(0.0));
  EXPECT_TRUE(schedule.Install(2, Rows({1, 2, 3}), 0));
  bool from_plan = false;
  const double expected[] = {0, 0, 1, 2, 3, 3, 3};
  const bool planned[] = {false, false, true, true, true, false, false};
  for (int step = 0; step < 7; ++step) {
    EXPECT_EQ(schedule.Take(step, &from_plan)(0), expected[step]) << step;
    EXPECT_EQ(from_plan, planned[step]) << step;
  }
}

// Committed inputs are what the plant applies: a plan that starts after them
// replaces only the later rows, and the holes were fixed to the held input.
TEST(InputScheduleTest, CommittedInputsAreAppliedWhateverArrivesLater) {
  InputSchedule schedule(U(0.0));
  schedule.Install(0, Rows({1, 2}), 0);
  const Eigen::MatrixXd committed = schedule.Commit(0, 4);  // 2 rows, then holds
  EXPECT_EQ(committed, Rows({1, 2, 2, 2}));
  EXPECT_TRUE(schedule.Install(4, Rows({7, 8}), 1));
  bool from_plan = false;
  const double expected[] = {1, 2, 2, 2, 7, 8};
  const bool planned[] = {true, true, false, false, true, true};
  for (int step = 0; step < 6; ++step) {
    EXPECT_EQ(schedule.Take(step, &from_plan)(0), expected[step]) << step;
    EXPECT_EQ(from_plan, planned[step]) << step;
  }
}

// A plan that arrives after its first step: the rows for passed steps are
// dropped, the rest apply.
TEST(InputScheduleTest, ALatePlanKeepsOnlyItsRowsStillAhead) {
  InputSchedule schedule(U(0.0));
  bool from_plan = false;
  schedule.Take(0, &from_plan);
  schedule.Take(1, &from_plan);
  EXPECT_FALSE(schedule.Install(1, Rows({4, 5, 6}), 2));
  EXPECT_EQ(schedule.Take(2, &from_plan)(0), 5);
  EXPECT_TRUE(from_plan);
  // A newer plan replaces the older one's rows from its start on.
  EXPECT_TRUE(schedule.Install(3, Rows({9}), 3));
  EXPECT_EQ(schedule.Take(3, &from_plan)(0), 9);
  EXPECT_EQ(schedule.Take(4, &from_plan)(0), 9);
  EXPECT_FALSE(from_plan);
}

}  // namespace
}  // namespace excite::sim
