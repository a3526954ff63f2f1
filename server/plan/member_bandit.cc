#include "server/plan/member_bandit.h"

#include <algorithm>
#include <cmath>

namespace excite::plan {

MemberBandit::MemberBandit(int members, double gamma)
    : gamma_(gamma), log_weights_(static_cast<size_t>(std::max(members, 1)), 0.0) {}

Eigen::VectorXd MemberBandit::Probabilities() const {
  const int k = members();
  const double top = *std::max_element(log_weights_.begin(), log_weights_.end());
  Eigen::VectorXd p(k);
  for (int i = 0; i < k; ++i) p(i) = std::exp(log_weights_[static_cast<size_t>(i)] - top);
  p = (1.0 - gamma_) * p / p.sum();
  p.array() += gamma_ / k;
  return p;
}

int MemberBandit::Draw(double u) const {
  const Eigen::VectorXd p = Probabilities();
  double cumulative = 0.0;
  for (int i = 0; i < p.size(); ++i) {
    cumulative += p(i);
    if (u < cumulative) return i;
  }
  return static_cast<int>(p.size()) - 1;  // u within rounding of 1
}

void MemberBandit::Reward(int member, double probability, double reward) {
  if (member < 0 || member >= members() || !(probability > 0.0)) return;
  const double r = std::clamp(std::isfinite(reward) ? reward : 0.0, 0.0, 1.0);
  log_weights_[static_cast<size_t>(member)] += gamma_ * r / (probability * members());
}

double SurpriseScale::Reward(const Eigen::VectorXd& error) {
  if (sum_squares_.size() != error.size()) {
    sum_squares_ = Eigen::VectorXd::Zero(error.size());
    count_ = 0;
  }
  const Eigen::ArrayXd squares = error.array().square();
  sum_squares_.array() += squares;
  ++count_;
  double q = 0.0;
  for (Eigen::Index d = 0; d < error.size(); ++d) {
    // A dimension the model has predicted exactly so far adds nothing.
    if (sum_squares_(d) > 0.0) q += squares(d) / (sum_squares_(d) / count_);
  }
  q /= std::max<Eigen::Index>(error.size(), 1);
  return q / (1.0 + q);
}

}  // namespace excite::plan
