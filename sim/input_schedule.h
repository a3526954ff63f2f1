#ifndef EXCITE_SIM_INPUT_SCHEDULE_H_
#define EXCITE_SIM_INPUT_SCHEDULE_H_

#include <cstdint>
#include <map>

#include "Eigen/Core"

namespace excite::sim {

// What a real-time plant applies at each step (excite-sim --realtime_hz): the
// rows of the plans that arrived, keyed by the step they are for, and a
// fallback where no plan reaches: hold the last input applied. Planning runs
// beside the plant, so a plan asked for at step t starts at t + P after P
// inputs committed now (Commit: the plan's pending_inputs) and covers the
// steps from there once it arrives (Install). Not thread-safe.
class InputSchedule {
 public:
  // `first`: what the fallback holds before any input was applied.
  explicit InputSchedule(Eigen::VectorXd first) : last_(std::move(first)) {}

  // The input for `step` (steps are taken in increasing order): the plan row for
  // it, or the last input again; `*from_plan` says which. Forgets older rows.
  Eigen::VectorXd Take(int64_t step, bool* from_plan);

  // Fixes the inputs of steps [step, step + count) and returns them (count x
  // input_dim): a plan's row where there is one, else the input the plant would
  // hold there. The plant applies exactly these, whatever arrives later.
  Eigen::MatrixXd Commit(int64_t step, int count);

  // Records `input` as applied outside the schedule (what the fallback then
  // holds).
  void Hold(Eigen::VectorXd input) { last_ = std::move(input); }

  // The plan whose first row is for `start` (a plan asked for after Commit(t, P)
  // has start t + P): its rows replace every row from `start` on; rows for steps
  // before `next_step` (already taken) are dropped. Returns whether it came in
  // time (start >= next_step).
  bool Install(int64_t start, const Eigen::MatrixXd& inputs, int64_t next_step);

 private:
  struct Row {
    Eigen::VectorXd input;
    bool from_plan = false;
  };
  std::map<int64_t, Row> rows_;
  Eigen::VectorXd last_;
};

}  // namespace excite::sim

#endif  // EXCITE_SIM_INPUT_SCHEDULE_H_
