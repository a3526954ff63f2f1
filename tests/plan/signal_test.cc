// The model-free signals: prbs, chirp and random (and their counter-based
// random numbers).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "server/plan/chirp_signal.h"
#include "server/plan/counter_random.h"
#include "server/plan/prbs_signal.h"
#include "server/plan/random_signal.h"

namespace excite::plan {
namespace {

constexpr double kPi = 3.141592653589793;

Eigen::VectorXd Lower() { return Eigen::Vector2d(-1.0, 0.0); }
Eigen::VectorXd Upper() { return Eigen::Vector2d(2.0, 5.0); }

// Lengths of the runs of equal consecutive values of one column.
std::vector<int> RunLengths(const Eigen::VectorXd& column) {
  std::vector<int> runs;
  int run = 1;
  for (Eigen::Index k = 1; k < column.size(); ++k) {
    if (column(k) == column(k - 1)) {
      ++run;
    } else {
      runs.push_back(run);
      run = 1;
    }
  }
  runs.push_back(run);
  return runs;
}

// The signal computed in chunks of varying size equals the one-shot signal: its
// value at k depends on (seed, k) only.
template <typename Signal>
void ExpectChunkInvariant(const Signal& signal, int total) {
  const Eigen::MatrixXd whole = signal(0, total);
  int k = 0;
  int chunk = 1;
  while (k < total) {
    const int count = std::min(chunk, total - k);
    const Eigen::MatrixXd part = signal(k, count);
    ASSERT_EQ(part.rows(), count);
    EXPECT_EQ(part, whole.middleRows(k, count)) << "chunk at " << k;
    k += count;
    chunk = chunk % 17 + 3;
  }
}

TEST(CounterRandomTest, DeterministicAndSensitiveToEveryWord) {
  const uint64_t base = CounterBits(1, 2, 3, 4);
  EXPECT_EQ(CounterBits(1, 2, 3, 4), base);
  EXPECT_NE(CounterBits(2, 2, 3, 4), base);
  EXPECT_NE(CounterBits(1, 3, 3, 4), base);
  EXPECT_NE(CounterBits(1, 2, 4, 4), base);
  EXPECT_NE(CounterBits(1, 2, 3, 5), base);
  // Swapping words changes the value (not a symmetric combination).
  EXPECT_NE(CounterBits(1, 2, 4, 3), base);
  double sum = 0.0;
  for (uint64_t k = 0; k < 100000; ++k) {
    const double u = CounterUniform(9, kRandomStream, 0, k);
    ASSERT_GE(u, 0.0);
    ASSERT_LT(u, 1.0);
    sum += u;
  }
  EXPECT_NEAR(sum / 100000, 0.5, 4.0 * std::sqrt(1.0 / 12.0 / 100000));
}

TEST(PrbsSignalTest, OnlyBoundsRunsAtLeastTheHoldAndSwitches) {
  for (int hold : {1, 3, 7}) {
    SCOPED_TRACE(hold);
    const int total = 3000;
    const Eigen::MatrixXd u = PrbsSignal(Lower(), Upper(), hold, 11, 0, total);
    ASSERT_EQ(u.rows(), total);
    ASSERT_EQ(u.cols(), 2);
    for (int j = 0; j < 2; ++j) {
      int high = 0;
      for (int k = 0; k < total; ++k) {
        ASSERT_TRUE(u(k, j) == Lower()(j) || u(k, j) == Upper()(j)) << k << " " << j;
        high += u(k, j) == Upper()(j) ? 1 : 0;
      }
      // A fair bit per clock period: both levels about half of the time.
      EXPECT_NEAR(static_cast<double>(high) / total, 0.5, 0.08);
      const std::vector<int> runs = RunLengths(u.col(j));
      // Switching happens: about one switch per two clock periods.
      EXPECT_GT(static_cast<int>(runs.size()), total / hold / 4);
      // Every run but the last (cut by the end of the signal) lasts a multiple of
      // the hold time, hence at least the hold time.
      for (size_t r = 0; r + 1 < runs.size(); ++r) {
        EXPECT_GE(runs[r], hold);
        EXPECT_EQ(runs[r] % hold, 0) << "run " << r;
      }
    }
    // The two dimensions are not the same sequence.
    EXPECT_NE((u.col(0).array() == Upper()(0)).matrix(),
              (u.col(1).array() == Upper()(1)).matrix());
  }
}

TEST(PrbsSignalTest, DeterministicPerSeedAndTimeIndex) {
  const auto signal = [](int64_t first, int count) {
    return PrbsSignal(Lower(), Upper(), 4, 5, first, count);
  };
  ExpectChunkInvariant(signal, 500);
  EXPECT_EQ(PrbsSignal(Lower(), Upper(), 4, 5, 0, 200),
            PrbsSignal(Lower(), Upper(), 4, 5, 0, 200));
  EXPECT_NE(PrbsSignal(Lower(), Upper(), 4, 5, 0, 200),
            PrbsSignal(Lower(), Upper(), 4, 6, 0, 200));
  // A run starting mid-period is still aligned with sample 0.
  const Eigen::MatrixXd from_two = PrbsSignal(Lower(), Upper(), 4, 5, 2, 10);
  EXPECT_EQ(from_two, PrbsSignal(Lower(), Upper(), 4, 5, 0, 12).bottomRows(10));
}

TEST(ChirpSignalTest, MatchesTheClosedFormAndStaysWithinBounds) {
  ChirpParams params;
  params.start_frequency = 0.02;
  params.end_frequency = 0.3;
  params.period = 150;
  const int total = 450;
  const Eigen::MatrixXd u = ChirpSignal(Lower(), Upper(), params, 0, total);
  ASSERT_EQ(u.rows(), total);
  double max0 = -1e9, min0 = 1e9;
  for (int k = 0; k < total; ++k) {
    const double tau = k % params.period;
    const double phase =
        2 * kPi * (0.02 * tau + (0.3 - 0.02) * tau * tau / (2.0 * params.period));
    for (int j = 0; j < 2; ++j) {
      const double c = 0.5 * (Lower()(j) + Upper()(j));
      const double a = 0.5 * (Upper()(j) - Lower()(j));
      EXPECT_NEAR(u(k, j), c + a * std::sin(phase + 2 * kPi * j / 2.0), 1e-9) << k;
      EXPECT_GE(u(k, j), Lower()(j));
      EXPECT_LE(u(k, j), Upper()(j));
    }
    max0 = std::max(max0, u(k, 0));
    min0 = std::min(min0, u(k, 0));
  }
  // The amplitude uses the whole range.
  EXPECT_GT(max0, Upper()(0) - 0.05);
  EXPECT_LT(min0, Lower()(0) + 0.05);
  // Periodic with the sweep period; the second dimension is in antiphase (du = 2).
  EXPECT_LT((u.middleRows(150, 150) - u.topRows(150)).cwiseAbs().maxCoeff(), 1e-9);
  const Eigen::VectorXd centred0 = u.col(0).array() - 0.5;
  const Eigen::VectorXd centred1 = u.col(1).array() - 2.5;
  EXPECT_LT((centred1 / 2.5 + centred0 / 1.5).cwiseAbs().maxCoeff(), 1e-9);
  ExpectChunkInvariant(
      [&](int64_t first, int count) {
        return ChirpSignal(Lower(), Upper(), params, first, count);
      },
      total);
}

// Zero crossings of one sweep, by linear interpolation; the local frequency is
// 1 / (2 * interval between consecutive crossings).
std::vector<double> ZeroCrossings(const ChirpParams& params) {
  const Eigen::VectorXd lower = Eigen::VectorXd::Constant(1, -1.0);
  const Eigen::VectorXd upper = Eigen::VectorXd::Constant(1, 1.0);
  const Eigen::MatrixXd u = ChirpSignal(lower, upper, params, 0, params.period);
  std::vector<double> crossings;
  for (int k = 1; k < params.period; ++k) {
    if ((u(k - 1, 0) < 0.0) != (u(k, 0) < 0.0)) {
      crossings.push_back(k - 1 + u(k - 1, 0) / (u(k - 1, 0) - u(k, 0)));
    }
  }
  return crossings;
}

TEST(ChirpSignalTest, InstantaneousFrequencySweepsFromStartToEnd) {
  for (const auto& [f0, f1] : {std::pair<double, double>{0.01, 0.1}, {0.1, 0.01}}) {
    SCOPED_TRACE(f0);
    ChirpParams params;
    params.start_frequency = f0;
    params.end_frequency = f1;
    params.period = 3000;
    const std::vector<double> crossings = ZeroCrossings(params);
    ASSERT_GT(crossings.size(), 50u);
    std::vector<double> intervals;
    for (size_t i = 1; i < crossings.size(); ++i) {
      const double interval = crossings[i] - crossings[i - 1];
      const double estimated = 1.0 / (2.0 * interval);
      const double expected =
          ChirpFrequency(params, 0.5 * (crossings[i] + crossings[i - 1]));
      EXPECT_NEAR(estimated, expected, 0.03 * expected) << "crossing " << i;
      intervals.push_back(interval);
    }
    // The estimated frequency spans [f0, f1]: it starts near f0 and ends near f1.
    const double first = 1.0 / (2.0 * intervals.front());
    const double last = 1.0 / (2.0 * intervals.back());
    EXPECT_NEAR(first, f0, 0.25 * std::min(f0, f1));
    EXPECT_NEAR(last, f1, 0.1 * std::max(f0, f1));
    // Up-sweep: the half-periods shrink from 1/(2 f0) to 1/(2 f1); down: they grow.
    // Compared by quarters of the crossings (single intervals jitter by the
    // sampling at high frequencies).
    const size_t q = intervals.size() / 4;
    std::vector<double> quarter_mean(4, 0.0);
    for (size_t i = 0; i < 4 * q; ++i) quarter_mean[i / q] += intervals[i] / q;
    for (int k = 1; k < 4; ++k) {
      if (f1 > f0) {
        EXPECT_LT(quarter_mean[k], quarter_mean[k - 1]) << k;
      } else {
        EXPECT_GT(quarter_mean[k], quarter_mean[k - 1]) << k;
      }
    }
  }
}

TEST(RandomSignalTest, HoldsUniformInputsWithinBounds) {
  const int hold = 3;
  const int total = 60000;
  const Eigen::MatrixXd u = RandomSignal(Lower(), Upper(), hold, 21, 0, total);
  ASSERT_EQ(u.rows(), total);
  for (int j = 0; j < 2; ++j) {
    const double lo = Lower()(j), hi = Upper()(j);
    std::vector<int> quartiles(4, 0);
    for (int k = 0; k < total; ++k) {
      ASSERT_GE(u(k, j), lo);
      ASSERT_LE(u(k, j), hi);
      if (k % hold != 0) {
        ASSERT_EQ(u(k, j), u(k - 1, j)) << k;  // held within a period
      } else if (k > 0) {
        ASSERT_NE(u(k, j), u(k - 1, j)) << k;  // a fresh value per period
      }
      ++quartiles[std::min(3, static_cast<int>(4.0 * (u(k, j) - lo) / (hi - lo)))];
    }
    // Uniform-ish: mean near the centre (4 standard errors over 20000 periods)
    // and each quartile near a quarter.
    const double width = hi - lo;
    EXPECT_NEAR(u.col(j).mean(), 0.5 * (lo + hi),
                4.0 * width / std::sqrt(12.0 * total / hold));
    for (int q = 0; q < 4; ++q) {
      EXPECT_NEAR(static_cast<double>(quartiles[q]) / total, 0.25, 0.015) << q;
    }
  }
  ExpectChunkInvariant(
      [](int64_t first, int count) {
        return RandomSignal(Lower(), Upper(), 3, 21, first, count);
      },
      400);
  EXPECT_NE(RandomSignal(Lower(), Upper(), 3, 21, 0, 30),
            RandomSignal(Lower(), Upper(), 3, 22, 0, 30));
}

}  // namespace
}  // namespace excite::plan
