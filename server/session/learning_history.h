#ifndef EXCITE_SERVER_SESSION_LEARNING_HISTORY_H_
#define EXCITE_SERVER_SESSION_LEARNING_HISTORY_H_

#include <Eigen/Dense>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "server/gp/dynamics_predictor.h"
#include "server/plan/plan_types.h"

namespace excite::session {

// One plan a session returned.
struct PlanRecord {
  int64_t sample_count = 0;  // the samples it was planned with
  int64_t model_version = 0;
  int64_t unix_ms = 0;  // when it was returned
  plan::Strategy planned_by = plan::Strategy::kRec;
  plan::PlanStatus status = plan::PlanStatus::kNotConverged;
  double objective = 0.0;
  double wall_time_ms = 0.0;
  int iterations = 0;
};

// The model's one-step error on a batch of transitions, predicted before the
// batch was added: an error on data the model had not seen, from the plant's
// own measurements (no ground truth needed).
struct BatchError {
  int64_t sample_count = 0;  // the samples the predicting model had
  int64_t batch_size = 0;
  int64_t model_version = 0;  // of the predicting model
  // Per state dimension, in its units (angles the shorter way round).
  Eigen::VectorXd rmse;
};

// The model's predictive standard deviation (latent, per state dimension, in
// its units), averaged over the region's reference set.
struct UncertaintyRecord {
  int64_t sample_count = 0;
  int64_t model_version = 0;
  Eigen::VectorXd mean_std;
};

// What a session learned as it went: a series per kind, oldest first, held in
// memory since the session was loaded. Each series keeps at most `capacity`
// records: when full, every second of its records is dropped, so a long
// session keeps its whole span at a coarser step.
class LearningHistory {
 public:
  static constexpr size_t kDefaultCapacity = 2048;
  explicit LearningHistory(size_t capacity = kDefaultCapacity);

  void Add(PlanRecord record) { Append(std::move(record), &plans_); }
  void Add(BatchError record) { Append(std::move(record), &batch_errors_); }
  void Add(UncertaintyRecord record) { Append(std::move(record), &uncertainty_); }

  const std::vector<PlanRecord>& plans() const { return plans_; }
  const std::vector<BatchError>& batch_errors() const { return batch_errors_; }
  const std::vector<UncertaintyRecord>& uncertainty() const { return uncertainty_; }

  // True when the uncertainty series wants a record at `sample_count`: the
  // first, or the session grew by 2 % (at least one sample) since the last one.
  // Bounds its cost (a reference set's variances) to O(1) per 2 % of growth.
  bool UncertaintyDue(int64_t sample_count) const;

 private:
  template <typename Record>
  void Append(Record record, std::vector<Record>* series) {
    if (series->size() >= capacity_) {
      size_t kept = 0;
      for (size_t i = 0; i < series->size(); i += 2) (*series)[kept++] = (*series)[i];
      series->resize(kept);
    }
    series->push_back(std::move(record));
  }

  size_t capacity_;
  std::vector<PlanRecord> plans_;
  std::vector<BatchError> batch_errors_;
  std::vector<UncertaintyRecord> uncertainty_;
};

// Root mean square, per state dimension, of next_states minus the model's mean
// prediction at (states, inputs); angle dimensions compared the shorter way
// round. The model must be able to predict (a fitted GP).
Eigen::VectorXd OneStepRmse(const gp::DynamicsPredictor& model,
                            const Eigen::MatrixXd& states, const Eigen::MatrixXd& inputs,
                            const Eigen::MatrixXd& next_states,
                            const std::vector<int>& angle_dims);

// The latent predictive standard deviation per state dimension, averaged over
// the rows of `reference` (points x (state_dim + input_dim)).
Eigen::VectorXd MeanPredictiveStd(const gp::DynamicsPredictor& model,
                                  const Eigen::MatrixXd& reference);

}  // namespace excite::session

#endif  // EXCITE_SERVER_SESSION_LEARNING_HISTORY_H_
