#ifndef EXCITE_SIM_EVALUATION_H_
#define EXCITE_SIM_EVALUATION_H_

#include <Eigen/Dense>
#include <cstdint>
#include <optional>
#include <vector>

#include "absl/status/statusor.h"
#include "sim/plants/plant.h"
#include "sim/portable_random.h"

namespace excite::sim {

// An axis-aligned box [lower, upper] (same size, lower < upper entrywise).
struct Box {
  Eigen::VectorXd lower;
  Eigen::VectorXd upper;
};

// A point drawn uniformly from a box (one Uniform per dimension, in order): the
// distribution of the evaluation set's inputs.
Eigen::VectorXd UniformPoint(const Box& box, PortableRandom& random);

// A state of `plant` drawn uniformly from `region`: the evaluation set's states.
// Each dimension is uniform in its interval, except that each of the plant's
// AnglePairs() gets one angle drawn uniformly from the arc whose sin and cos lie in
// their intervals (by rejection from the full circle), so that the state is one
// the plant can be in. INVALID_ARGUMENT if an arc is empty or too short to hit in
// 100000 draws (under 1e-4 of the circle).
absl::StatusOr<Eigen::VectorXd> UniformState(const Plant& plant, const Box& region,
                                             PortableRandom& random);

// The points a model is scored on: z_p = (x_p, u_p) with x_p = UniformState(plant,
// region) and u_p uniform in the input box, and the plant's true next state f(z_p).
struct EvaluationSet {
  Eigen::MatrixXd inputs;  // points x (state_dim + input_dim), rows z_p = (x_p, u_p).
  Eigen::MatrixXd next_states;  // points x state_dim, rows f(z_p) (noise-free).
};

// Draws `points` z_p with PortableRandom(seed) (the same set for a given seed on
// every platform, hence for every strategy compared) and steps the plant once from
// each. INVALID_ARGUMENT if points < 1 or a box does not match the plant's dims or
// has lower >= upper. O(points) plant steps.
absl::StatusOr<EvaluationSet> MakeEvaluationSet(const Plant& plant, const Box& region,
                                                const Box& inputs, int points,
                                                uint64_t seed);

// Root mean square prediction error over the P rows of the evaluation set:
//   RMSE = sqrt( (1/P) * sum_p || mean_p - f(z_p) ||_2^2 ),
// i.e. the squared Euclidean error is summed over the state dimensions (not
// averaged) and averaged over the points. The paper (Section 6) says only "RMSE over
// a grid of uniformly random states and inputs"; this is our reading of it, in
// state units. INVALID_ARGUMENT if the shapes differ or there are no rows.
// An angle's error (angle_dims: state dimensions that are angles) is the shorter
// way round the circle.
absl::StatusOr<double> Rmse(const Eigen::MatrixXd& predicted_mean,
                            const Eigen::MatrixXd& true_next_states,
                            const std::vector<int>& angle_dims = {});

// The same per state dimension j: sqrt( (1/P) * sum_p (mean_pj - f(z_p)_j)^2 ), so
// that RMSE^2 is the sum of their squares: which dimensions the error comes from.
// Errors as Rmse().
absl::StatusOr<Eigen::VectorXd> RmsePerDimension(const Eigen::MatrixXd& predicted_mean,
                                                 const Eigen::MatrixXd& true_next_states,
                                                 const std::vector<int>& angle_dims = {});

// predicted - truth (rows of states), each angle's column (angle_dims) wrapped to
// (-pi, pi]: the shorter way round.
Eigen::MatrixXd PredictionErrors(const Eigen::MatrixXd& predicted,
                                 const Eigen::MatrixXd& truth,
                                 const std::vector<int>& angle_dims);

// `states` (one per row) with each angle's column (angle_dims) moved by whole
// turns into [lower, lower + 2 pi): where on the circle each state is, counted
// from the turn that starts at `lower` (a region's or a box's lower bounds), for
// coverage and boxes.
Eigen::MatrixXd OnTheCircle(const Eigen::MatrixXd& states, const Eigen::VectorXd& lower,
                            const std::vector<int>& angle_dims);

// How well the predictive variances fit the errors, over every (point, state
// dimension) pair of a Predict of latent N(mean, variance) against the noise-free
// truth (angles' errors wrapped): the mean negative log predictive density (nats;
// lower is better, and overconfidence costs most) and the share of errors within
// the 95 % interval mean +- 1.96 sd (0.95 when calibrated). Shapes must match.
struct Calibration {
  double nlpd = 0.0;
  double inside_95 = 0.0;
};
Calibration ComputeCalibration(const Eigen::MatrixXd& mean,
                               const Eigen::MatrixXd& variance,
                               const Eigen::MatrixXd& truth,
                               const std::vector<int>& angle_dims);

// Trajectories of the plant for multi-step (open-loop) prediction errors: `count`
// starts UniformState(region), each driven `steps` steps by inputs drawn uniformly
// from the input box, one per step, all from PortableRandom(seed) (the same set for
// every strategy compared).
struct RolloutSet {
  std::vector<Eigen::MatrixXd> states;  // steps + 1 entries of count x state_dim
  std::vector<Eigen::MatrixXd> inputs;  // steps entries of count x input_dim
};
absl::StatusOr<RolloutSet> MakeRolloutSet(const Plant& plant, const Box& region,
                                          const Box& inputs, int count, int steps,
                                          uint64_t seed);

// The joint coverage is computed up to this state dimension (bins^dim cells).
inline constexpr int kMaxJointCoverageDim = 4;

struct Coverage {
  // Mean over the state dimensions d of (number of the `marginal_bins` equal bins of
  // [lower_d, upper_d] that contain x_d of at least one visited state) / bins.
  double marginal = 0.0;
  // (number of the joint_bins^state_dim equal cells of the region that contain at
  // least one visited state) / joint_bins^state_dim; nullopt ("not computed") when
  // state_dim > kMaxJointCoverageDim.
  std::optional<double> joint;
};

// Coverage of `region` by `visited` (n x state_dim, one state per row; the true,
// noise-free states). Bins are half-open [a, b) except the last, which includes
// upper; values outside the region fall in no bin (for the joint coverage a state
// counts only if all its coordinates are inside). Both fractions are in [0, 1].
// INVALID_ARGUMENT on a bin count < 1, a region that does not match `visited` or
// has lower >= upper, or joint_bins^state_dim > 1e15. O(n state_dim) time and
// memory.
absl::StatusOr<Coverage> ComputeCoverage(const Eigen::MatrixXd& visited,
                                         const Box& region, int marginal_bins,
                                         int joint_bins);

// Fraction of the rows of `visited` (n x state_dim) with any coordinate outside
// [box.lower, box.upper] (bounds included in the box); 0 if there are no rows.
// The shapes must match (a precondition). O(n state_dim).
double FractionOutside(const Eigen::MatrixXd& visited, const Box& box);

}  // namespace excite::sim

#endif  // EXCITE_SIM_EVALUATION_H_
