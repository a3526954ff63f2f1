#include "sim/input_schedule.h"

#include <utility>

namespace excite::sim {

Eigen::VectorXd InputSchedule::Take(int64_t step, bool* from_plan) {
  rows_.erase(rows_.begin(), rows_.lower_bound(step));
  auto it = rows_.find(step);
  *from_plan = it != rows_.end() && it->second.from_plan;
  if (it != rows_.end()) {
    last_ = it->second.input;
    rows_.erase(it);
  }
  return last_;
}

Eigen::MatrixXd InputSchedule::Commit(int64_t step, int count) {
  Eigen::MatrixXd committed(count, last_.size());
  Eigen::VectorXd held = last_;
  for (int i = 0; i < count; ++i) {
    auto it = rows_.find(step + i);
    if (it == rows_.end()) {
      // A fallback row, fixed now so that a later plan cannot change it.
      it = rows_.emplace(step + i, Row{held, false}).first;
    }
    held = it->second.input;
    committed.row(i) = held.transpose();
  }
  return committed;
}

bool InputSchedule::Install(int64_t start, const Eigen::MatrixXd& inputs,
                            int64_t next_step) {
  rows_.erase(rows_.lower_bound(start), rows_.end());
  for (Eigen::Index i = 0; i < inputs.rows(); ++i) {
    const int64_t step = start + i;
    if (step >= next_step) rows_[step] = Row{inputs.row(i).transpose(), true};
  }
  return start >= next_step;
}

}  // namespace excite::sim
