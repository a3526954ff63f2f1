#ifndef EXCITE_SERVER_PLAN_REFERENCE_SET_H_
#define EXCITE_SERVER_PLAN_REFERENCE_SET_H_

#include <Eigen/Dense>
#include <cstdint>

namespace excite::plan {

// `count` points spread evenly over the box [lower, upper] (count x dim): a
// Halton sequence (bases 2, 3, 5, ...; dim <= 64) with a seeded random shift
// modulo 1 per dimension (Cranley-Patterson rotation), so that different seeds
// give different but equally even sets. A pure function of its arguments, the
// same on every platform. O(count dim log count).
Eigen::MatrixXd HaltonReferenceSet(const Eigen::VectorXd& lower,
                                   const Eigen::VectorXd& upper, int count,
                                   uint64_t seed);

}  // namespace excite::plan

#endif  // EXCITE_SERVER_PLAN_REFERENCE_SET_H_
