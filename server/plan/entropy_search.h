#ifndef EXCITE_SERVER_PLAN_ENTROPY_SEARCH_H_
#define EXCITE_SERVER_PLAN_ENTROPY_SEARCH_H_

#include <Eigen/Dense>
#include <cstdint>
#include <functional>
#include <limits>

#include "server/gp/dynamics_predictor.h"

namespace excite::plan {

// H(z) = sum_j 1/2 log(2 pi e var_j(z)) of one point z (z_dim), and, if `gradient`
// is not null, its analytic gradient dH/dz (z_dim) from the model's variance
// Jacobian. -infinity if the model's variance is not finite at z.
double PointEntropy(const gp::DynamicsPredictor& model, const Eigen::VectorXd& z,
                    Eigen::VectorXd* gradient);

struct EntropySearchOptions {
  int starts = 4;       // L-BFGS-B starts (>= 1)
  int samples = 256;    // uniform random samples; the best is the first start
  int iterations = 50;  // L-BFGS-B iterations per start
  uint64_t seed = 0;
};

struct EntropySearchResult {
  Eigen::VectorXd z;  // the best point found (empty if no finite entropy anywhere)
  double entropy = -std::numeric_limits<double>::infinity();
  int iterations = 0;     // L-BFGS-B iterations, summed over starts
  int evaluations = 0;    // PointEntropy calls with gradient
  int failed_starts = 0;  // starts that ended in an LBFGSpp exception
  bool stopped = false;   // `stop` fired
};

// sep's search (paper, eq. submodular_greedy_procedure): z* = argmax H(z) over the
// box [lower, upper] (z_dim entries each, lower <= upper, finite). Multi-start
// L-BFGS-B (LBFGSpp's LBFGSBSolver) on -H in box-normalised coordinates
// s = (z - centre) / half-width in [-1, 1], with the analytic gradient. Starts: the
// best of `samples` uniform random points of the box (one batched Predict), then
// `starts - 1` further uniform random points; all from mt19937_64(seed). Every
// evaluated point is a candidate, so a start that ends in an LBFGSpp exception
// (line-search failure, ...) still contributes its best iterate. `stop` is polled
// at every evaluation; when it fires the best point so far is returned.
EntropySearchResult SearchMaxEntropy(const gp::DynamicsPredictor& model,
                                     const Eigen::VectorXd& lower,
                                     const Eigen::VectorXd& upper,
                                     const EntropySearchOptions& options,
                                     const std::function<bool()>& stop);

}  // namespace excite::plan

#endif  // EXCITE_SERVER_PLAN_ENTROPY_SEARCH_H_
