#include "sim/evaluation.h"

#include <cmath>
#include <cstdint>
#include <unordered_set>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "common/angles.h"
#include "sim/portable_random.h"

namespace excite::sim {
namespace {

absl::Status CheckBox(const Box& box, int dim, const char* what) {
  if (box.lower.size() != dim || box.upper.size() != dim) {
    return absl::InvalidArgumentError(absl::StrCat(what, " has ", box.lower.size(), "/",
                                                   box.upper.size(), " bounds, expected ",
                                                   dim));
  }
  for (int i = 0; i < dim; ++i) {
    if (!(box.lower(i) < box.upper(i)) || !std::isfinite(box.lower(i)) ||
        !std::isfinite(box.upper(i))) {
      return absl::InvalidArgumentError(
          absl::StrCat(what, " dimension ", i, ": need finite lower < upper, got [",
                       box.lower(i), ", ", box.upper(i), "]"));
    }
  }
  return absl::OkStatus();
}

// The bin of v among `bins` equal bins of [lower, upper], or -1 if v is outside.
int BinOf(double v, double lower, double upper, int bins) {
  if (!(v >= lower && v <= upper)) return -1;
  const int bin = static_cast<int>(std::floor((v - lower) / (upper - lower) * bins));
  return bin >= bins ? bins - 1 : bin;
}

}  // namespace

Eigen::VectorXd UniformPoint(const Box& box, PortableRandom& random) {
  Eigen::VectorXd point(box.lower.size());
  for (Eigen::Index i = 0; i < point.size(); ++i) {
    point(i) = random.Uniform(box.lower(i), box.upper(i));
  }
  return point;
}

absl::StatusOr<Eigen::VectorXd> UniformState(const Plant& plant, const Box& region,
                                             PortableRandom& random) {
  constexpr int kMaxDraws = 100000;
  Eigen::VectorXd x = UniformPoint(region, random);
  for (const auto& [s, c] : plant.AnglePairs()) {
    int draw = 0;
    for (; draw < kMaxDraws; ++draw) {
      const double angle = random.Uniform(-kPi, kPi);
      x(s) = std::sin(angle);
      x(c) = std::cos(angle);
      if (x(s) >= region.lower(s) && x(s) <= region.upper(s) && x(c) >= region.lower(c) &&
          x(c) <= region.upper(c)) {
        break;
      }
    }
    if (draw == kMaxDraws) {
      return absl::InvalidArgumentError(
          absl::StrCat("state region: dimensions ", s, " and ", c,
                       " hold one angle as (sin, cos), "
                       "and no angle (or too short an arc) has both in [",
                       region.lower(s), ", ", region.upper(s), "] x [", region.lower(c),
                       ", ", region.upper(c), "]"));
    }
  }
  return x;
}

absl::StatusOr<EvaluationSet> MakeEvaluationSet(const Plant& plant, const Box& region,
                                                const Box& inputs, int points,
                                                uint64_t seed) {
  if (points < 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("evaluation points must be >= 1, got ", points));
  }
  const int dx = plant.state_dim();
  const int du = plant.input_dim();
  if (absl::Status s = CheckBox(region, dx, "state region"); !s.ok()) return s;
  if (absl::Status s = CheckBox(inputs, du, "input bounds"); !s.ok()) return s;

  PortableRandom random(seed);
  EvaluationSet set;
  set.inputs.resize(points, dx + du);
  set.next_states.resize(points, dx);
  for (int p = 0; p < points; ++p) {
    absl::StatusOr<Eigen::VectorXd> x = UniformState(plant, region, random);
    if (!x.ok()) return x.status();
    const Eigen::VectorXd u = UniformPoint(inputs, random);
    set.inputs.row(p).head(dx) = x->transpose();
    set.inputs.row(p).tail(du) = u.transpose();
    set.next_states.row(p) = plant.Step(*x, u).transpose();
  }
  return set;
}

Eigen::MatrixXd PredictionErrors(const Eigen::MatrixXd& predicted,
                                 const Eigen::MatrixXd& truth,
                                 const std::vector<int>& angle_dims) {
  Eigen::MatrixXd errors = predicted - truth;
  for (int a : angle_dims) errors.col(a) = errors.col(a).unaryExpr(&WrapAngle);
  return errors;
}

Eigen::MatrixXd OnTheCircle(const Eigen::MatrixXd& states, const Eigen::VectorXd& lower,
                            const std::vector<int>& angle_dims) {
  Eigen::MatrixXd out = states;
  for (int a : angle_dims) {
    for (Eigen::Index i = 0; i < out.rows(); ++i) {
      const double turns = std::floor((out(i, a) - lower(a)) / (2.0 * kPi));
      out(i, a) -= 2.0 * kPi * turns;
    }
  }
  return out;
}

Calibration ComputeCalibration(const Eigen::MatrixXd& mean,
                               const Eigen::MatrixXd& variance,
                               const Eigen::MatrixXd& truth,
                               const std::vector<int>& angle_dims) {
  const Eigen::ArrayXXd error = PredictionErrors(mean, truth, angle_dims).array();
  // A variance of 0 (a clamped round-off) would make the density infinite: floor it.
  const Eigen::ArrayXXd var = variance.array().max(1e-300);
  Calibration c;
  const double n = static_cast<double>(error.size());
  c.nlpd = (0.5 * (2.0 * kPi * var).log() + 0.5 * error.square() / var).sum() / n;
  c.inside_95 = (error.abs() <= 1.959963984540054 * var.sqrt()).cast<double>().sum() / n;
  return c;
}

absl::StatusOr<RolloutSet> MakeRolloutSet(const Plant& plant, const Box& region,
                                          const Box& inputs, int count, int steps,
                                          uint64_t seed) {
  if (count < 1 || steps < 1) {
    return absl::InvalidArgumentError(absl::StrCat(
        "rollouts need count >= 1 and steps >= 1, got ", count, " and ", steps));
  }
  const int dx = plant.state_dim();
  const int du = plant.input_dim();
  if (absl::Status s = CheckBox(region, dx, "state region"); !s.ok()) return s;
  if (absl::Status s = CheckBox(inputs, du, "input bounds"); !s.ok()) return s;
  PortableRandom random(seed);
  RolloutSet set;
  set.states.assign(steps + 1, Eigen::MatrixXd(count, dx));
  set.inputs.assign(steps, Eigen::MatrixXd(count, du));
  for (int r = 0; r < count; ++r) {
    absl::StatusOr<Eigen::VectorXd> x = UniformState(plant, region, random);
    if (!x.ok()) return x.status();
    set.states[0].row(r) = x->transpose();
    for (int k = 0; k < steps; ++k) {
      const Eigen::VectorXd u = UniformPoint(inputs, random);
      set.inputs[k].row(r) = u.transpose();
      *x = plant.Step(*x, u);
      set.states[k + 1].row(r) = x->transpose();
    }
  }
  return set;
}

absl::StatusOr<double> Rmse(const Eigen::MatrixXd& predicted_mean,
                            const Eigen::MatrixXd& true_next_states,
                            const std::vector<int>& angle_dims) {
  if (predicted_mean.rows() != true_next_states.rows() ||
      predicted_mean.cols() != true_next_states.cols()) {
    return absl::InvalidArgumentError(
        absl::StrCat("RMSE of a ", predicted_mean.rows(), "x", predicted_mean.cols(),
                     " prediction against ", true_next_states.rows(), "x",
                     true_next_states.cols(), " true states"));
  }
  if (predicted_mean.rows() == 0) {
    return absl::InvalidArgumentError("RMSE of an empty evaluation set");
  }
  const double squared_sum =
      PredictionErrors(predicted_mean, true_next_states, angle_dims).squaredNorm();
  return std::sqrt(squared_sum / static_cast<double>(predicted_mean.rows()));
}

absl::StatusOr<Eigen::VectorXd> RmsePerDimension(const Eigen::MatrixXd& predicted_mean,
                                                 const Eigen::MatrixXd& true_next_states,
                                                 const std::vector<int>& angle_dims) {
  // Rmse() checks the shapes and rows.
  if (absl::StatusOr<double> total = Rmse(predicted_mean, true_next_states);
      !total.ok()) {
    return total.status();
  }
  return (PredictionErrors(predicted_mean, true_next_states, angle_dims)
              .colwise()
              .squaredNorm() /
          static_cast<double>(predicted_mean.rows()))
      .cwiseSqrt()
      .transpose();
}

absl::StatusOr<Coverage> ComputeCoverage(const Eigen::MatrixXd& visited,
                                         const Box& region, int marginal_bins,
                                         int joint_bins) {
  const int dx = static_cast<int>(visited.cols());
  if (dx < 1) return absl::InvalidArgumentError("coverage of states with no dimension");
  if (marginal_bins < 1 || joint_bins < 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("coverage bins must be >= 1, got marginal ", marginal_bins,
                     ", joint ", joint_bins));
  }
  if (absl::Status s = CheckBox(region, dx, "coverage region"); !s.ok()) return s;

  Coverage coverage;
  double marginal_sum = 0.0;
  for (int d = 0; d < dx; ++d) {
    std::vector<bool> hit(marginal_bins, false);
    int hits = 0;
    for (Eigen::Index n = 0; n < visited.rows(); ++n) {
      const int bin =
          BinOf(visited(n, d), region.lower(d), region.upper(d), marginal_bins);
      if (bin >= 0 && !hit[bin]) {
        hit[bin] = true;
        ++hits;
      }
    }
    marginal_sum += static_cast<double>(hits) / marginal_bins;
  }
  coverage.marginal = marginal_sum / dx;

  if (dx <= kMaxJointCoverageDim) {
    const double cells = std::pow(static_cast<double>(joint_bins), dx);
    if (cells > 1e15) {
      return absl::InvalidArgumentError(absl::StrCat("joint coverage with ", joint_bins,
                                                     "^", dx, " cells is too fine"));
    }
    std::unordered_set<int64_t> hit;
    for (Eigen::Index n = 0; n < visited.rows(); ++n) {
      int64_t cell = 0;
      bool inside = true;
      for (int d = 0; d < dx && inside; ++d) {
        const int bin =
            BinOf(visited(n, d), region.lower(d), region.upper(d), joint_bins);
        inside = bin >= 0;
        cell = cell * joint_bins + bin;
      }
      if (inside) hit.insert(cell);
    }
    coverage.joint = static_cast<double>(hit.size()) / cells;
  }
  return coverage;
}

double FractionOutside(const Eigen::MatrixXd& visited, const Box& box) {
  if (visited.rows() == 0) return 0.0;
  Eigen::Index outside = 0;
  for (Eigen::Index i = 0; i < visited.rows(); ++i) {
    const Eigen::ArrayXd x = visited.row(i).transpose().array();
    if ((x < box.lower.array()).any() || (x > box.upper.array()).any()) ++outside;
  }
  return static_cast<double>(outside) / static_cast<double>(visited.rows());
}

}  // namespace excite::sim
