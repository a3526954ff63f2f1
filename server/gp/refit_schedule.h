#ifndef EXCITE_SERVER_GP_REFIT_SCHEDULE_H_
#define EXCITE_SERVER_GP_REFIT_SCHEDULE_H_

namespace excite::gp {

// When a growing model's hyperparameters are refitted. Between refits a new
// sample costs O(n^2) per output (DynamicsModel appends a row to its Cholesky
// factor) instead of an O(n^3) fit, and the ML-II optimum of n samples moves
// little when a few percent more arrive: spacing refits geometrically bounds
// their amortised cost per sample at O(n^2 / growth).
struct RefitSchedule {
  // A refit needs at least this many samples since the last fit (>= 1).
  int every_samples = 1;
  // ... and at least this fraction of the samples the last fit saw (>= 0;
  // 0: every_samples alone decides).
  double growth = 0.0;
};

// Whether a model with `sample_count` samples, `samples_since_fit` of them
// added after its last fit, is due: samples_since_fit >= max(every_samples,
// ceil(growth * (sample_count - samples_since_fit))). A never-fitted model has
// all its samples since the fit, so it is due once it has every_samples.
bool RefitDue(const RefitSchedule& schedule, int sample_count, int samples_since_fit);

}  // namespace excite::gp

#endif  // EXCITE_SERVER_GP_REFIT_SCHEDULE_H_
