#include "server/plan/entropy_search.h"

#include <LBFGSB.h>

#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>
#include <random>
#include <utility>
#include <vector>

#include "server/plan/entropy_objective.h"

namespace excite::plan {
namespace {

// Thrown by the objective when `stop` fires, to leave LBFGSpp at once.
struct SearchStopped {};

// Uniform in [0, 1) from 53 random bits: the same on every platform.
double Uniform01(std::mt19937_64& rng) {
  return static_cast<double>(rng() >> 11) * 0x1.0p-53;
}

// -H in box-normalised coordinates, remembering the best point it evaluated.
class NegativeEntropy {
 public:
  NegativeEntropy(const gp::DynamicsPredictor& model, Eigen::VectorXd centre,
                  Eigen::VectorXd half_width, const std::function<bool()>& stop,
                  EntropySearchResult* result)
      : model_(model),
        centre_(std::move(centre)),
        half_width_(std::move(half_width)),
        stop_(stop),
        result_(result) {}

  double operator()(const Eigen::VectorXd& s, Eigen::VectorXd& gradient) {
    if (stop_ && stop_()) {
      result_->stopped = true;
      throw SearchStopped{};
    }
    ++result_->evaluations;
    const Eigen::VectorXd z = centre_ + half_width_.cwiseProduct(s);
    Eigen::VectorXd dz;
    const double h = PointEntropy(model_, z, &dz);
    if (!std::isfinite(h) || !dz.allFinite()) {
      gradient.setZero(s.size());
      return std::numeric_limits<double>::infinity();
    }
    if (h > result_->entropy) {
      result_->entropy = h;
      result_->z = z;
    }
    gradient = -dz.cwiseProduct(half_width_);
    return -h;
  }

 private:
  const gp::DynamicsPredictor& model_;
  const Eigen::VectorXd centre_;
  const Eigen::VectorXd half_width_;
  const std::function<bool()>& stop_;
  EntropySearchResult* result_;
};

}  // namespace

double PointEntropy(const gp::DynamicsPredictor& model, const Eigen::VectorXd& z,
                    Eigen::VectorXd* gradient) {
  const Eigen::MatrixXd point = z.transpose();
  Eigen::MatrixXd mean;
  Eigen::MatrixXd variance;
  std::vector<Eigen::MatrixXd> mean_jacobians;
  std::vector<Eigen::MatrixXd> variance_jacobians;
  model.Predict(point, &mean, &variance, nullptr,
                gradient != nullptr ? &variance_jacobians : nullptr);
  if (variance.rows() != 1 || variance.cols() != model.state_dim() ||
      !variance.allFinite()) {
    if (gradient != nullptr) gradient->setZero(z.size());
    return -std::numeric_limits<double>::infinity();
  }
  if (gradient != nullptr) {
    if (variance_jacobians.size() != 1) {
      gradient->setZero(z.size());
      return -std::numeric_limits<double>::infinity();
    }
    *gradient = EntropyGradient(variance.row(0).transpose(), variance_jacobians[0]);
  }
  return Entropy(variance);
}

EntropySearchResult SearchMaxEntropy(const gp::DynamicsPredictor& model,
                                     const Eigen::VectorXd& lower,
                                     const Eigen::VectorXd& upper,
                                     const EntropySearchOptions& options,
                                     const std::function<bool()>& stop) {
  EntropySearchResult result;
  const Eigen::Index d = lower.size();
  const Eigen::VectorXd centre = 0.5 * (lower + upper);
  const Eigen::VectorXd half_width = 0.5 * (upper - lower);
  std::mt19937_64 rng(options.seed);
  const auto uniform_point = [&] {
    Eigen::VectorXd s(d);
    for (Eigen::Index l = 0; l < d; ++l) s(l) = 2.0 * Uniform01(rng) - 1.0;
    return s;
  };

  // The batch: one Predict of all samples; its best point is the first start.
  std::vector<Eigen::VectorXd> starts;
  const int samples = std::max(options.samples, 1);
  Eigen::MatrixXd batch(samples, d);
  for (int i = 0; i < samples; ++i) {
    batch.row(i) = (centre + half_width.cwiseProduct(uniform_point())).transpose();
  }
  Eigen::MatrixXd mean;
  Eigen::MatrixXd variance;
  model.Predict(batch, &mean, &variance, nullptr, nullptr);
  int best_sample = -1;
  if (variance.rows() == samples && variance.cols() == model.state_dim()) {
    for (int i = 0; i < samples; ++i) {
      if (!variance.row(i).allFinite()) continue;
      const double h = Entropy(variance.row(i));
      if (h > result.entropy) {
        result.entropy = h;
        result.z = batch.row(i).transpose();
        best_sample = i;
      }
    }
  }
  if (best_sample >= 0) {
    starts.push_back((batch.row(best_sample).transpose() - centre)
                         .cwiseQuotient(half_width.cwiseMax(1e-300)));
  }
  while (static_cast<int>(starts.size()) < std::max(options.starts, 1)) {
    starts.push_back(uniform_point());
  }

  LBFGSpp::LBFGSBParam<double> param;
  param.m = 6;
  param.max_iterations = std::max(options.iterations, 1);
  param.epsilon = 1e-6;
  param.epsilon_rel = 0.0;
  param.past = 1;
  param.delta = 1e-10;
  LBFGSpp::LBFGSBSolver<double> solver(param);
  const Eigen::VectorXd lb = -Eigen::VectorXd::Ones(d);
  const Eigen::VectorXd ub = Eigen::VectorXd::Ones(d);
  NegativeEntropy objective(model, centre, half_width, stop, &result);
  for (const Eigen::VectorXd& start : starts) {
    Eigen::VectorXd s = start.cwiseMax(lb).cwiseMin(ub);
    double f = 0.0;
    try {
      result.iterations += solver.minimize(objective, s, f, lb, ub);
    } catch (const SearchStopped&) {
      break;
    } catch (const std::exception&) {
      // Line-search failure and the like: the objective kept the best iterate.
      ++result.failed_starts;
    }
  }
  if (result.z.size() == d) result.z = result.z.cwiseMax(lower).cwiseMin(upper);
  return result;
}

}  // namespace excite::plan
