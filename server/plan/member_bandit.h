#ifndef EXCITE_SERVER_PLAN_MEMBER_BANDIT_H_
#define EXCITE_SERVER_PLAN_MEMBER_BANDIT_H_

#include <Eigen/Dense>
#include <vector>

namespace excite::plan {

// EXP3 (Auer, Cesa-Bianchi, Freund and Schapire, "The nonstochastic multiarmed
// bandit problem", 2002) over `auto`'s members: adversarial rewards, because a
// member's reward shrinks as the model learns from every member's data.
class MemberBandit {
 public:
  // members >= 1; gamma in (0, 1]: the share of draws spread uniformly, so every
  // member keeps probability >= gamma / members.
  MemberBandit(int members, double gamma);

  int members() const { return static_cast<int>(log_weights_.size()); }
  // p_k = (1 - gamma) w_k / sum w + gamma / K.
  Eigen::VectorXd Probabilities() const;
  // The member drawn by u in [0, 1) (inverse CDF of Probabilities()).
  int Draw(double u) const;
  // The drawn member's reward in [0, 1] (clamped), importance weighted by the
  // probability it was drawn with: w_k *= exp(gamma r / (p_k K)).
  void Reward(int member, double probability, double reward);

 private:
  double gamma_;
  std::vector<double> log_weights_;  // log w_k: no overflow over long sessions
};

// The reward of one transition: the model's one-step error e (state_dim) scaled
// per dimension by the mean squared error of every transition scored so far,
// this one included (so rewards stay in [0, 1) as the error shrinks):
// q = mean_d e_d^2 / s_d, r = q / (1 + q).
class SurpriseScale {
 public:
  double Reward(const Eigen::VectorXd& error);

 private:
  Eigen::VectorXd sum_squares_;
  long count_ = 0;
};

}  // namespace excite::plan

#endif  // EXCITE_SERVER_PLAN_MEMBER_BANDIT_H_
