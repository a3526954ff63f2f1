#ifndef EXCITE_SERVER_PLAN_SAFE_BOX_H_
#define EXCITE_SERVER_PLAN_SAFE_BOX_H_

#include <Eigen/Dense>

namespace excite::plan {

// State constraints of a plan: every predicted next state x_{i+1} ~ N(mean(z_i),
// var(z_i)) of the horizon must stay in [lower, upper] with a margin of `margin`
// one-step predictive (latent) standard deviations per dimension:
//   lower_j + margin sd_j(z_i) <= mean_j(z_i) <= upper_j - margin sd_j(z_i).
// Empty bounds mean no constraint. A box may differ from the region of interest.
struct SafeBox {
  Eigen::VectorXd lower;  // state_dim entries, or empty (no constraint)
  Eigen::VectorXd upper;  // state_dim entries, or empty
  double margin = 2.0;    // kappa >= 0, in standard deviations

  bool active() const { return lower.size() > 0; }
};

// Violations up to this (state units) count as keeping the box.
inline constexpr double kSafeBoxTolerance = 1e-6;

// The largest violation of the box by a horizon's predictions (mean, variance:
// M x state_dim, row i predicted at z_i), in state units: max over i, j of
// lower_j + margin sd_j - mean_j and mean_j + margin sd_j - upper_j, or 0 if none
// exceeds kSafeBoxTolerance (or the box is inactive).
double SafeBoxViolation(const SafeBox& box, const Eigen::MatrixXd& mean,
                        const Eigen::MatrixXd& variance);

}  // namespace excite::plan

#endif  // EXCITE_SERVER_PLAN_SAFE_BOX_H_
