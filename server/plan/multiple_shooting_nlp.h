#ifndef EXCITE_SERVER_PLAN_MULTIPLE_SHOOTING_NLP_H_
#define EXCITE_SERVER_PLAN_MULTIPLE_SHOOTING_NLP_H_

#include <Eigen/Dense>
#include <IpTNLP.hpp>
#include <functional>
#include <limits>
#include <vector>

#include "server/gp/dynamics_predictor.h"
#include "server/plan/safe_box.h"
#include "server/plan/shooting_objective.h"

namespace excite::plan {

// A horizon of M steps through the model mean as an Ipopt NLP by direct multiple
// shooting:
//   min_w  J(z_0, .., z_{M-1})       (a ShootingObjective; z_i = (x_i, u_i))
//   s.t.   x_{i+1} - mean(x_i, u_i) = 0,  i = 0..M-2;   lower <= u_i <= upper,
// with x_0 given. With NegativeEntropyObjective (the default constructor) this is
// the paper's problem (trajopt_optim), J = -sum_i H(x_i, u_i); sep steers with
// SteeringObjective. Decision vector w = (u_0, .., u_{M-1}, x_1, .., x_{M-1}), i.e.
// n = M du + (M-1) dx variables and (M-1) dx constraints. First derivatives are
// exact: all values and Jacobians at an iterate come from ONE batched
// DynamicsPredictor::Predict call of M points (cached per iterate). No Hessian:
// use hessian_approximation = limited-memory. The model and the objective must
// outlive the NLP. Keeps the best feasible point it evaluated (dynamics and safe
// box violated by at most feasibility_tolerance, lowest J), so a cut-short solve
// still has something good.
class MultipleShootingNlp final : public Ipopt::TNLP {
 public:
  // Polled once per Ipopt iteration; true stops the solve (User_Requested_Stop).
  using StopFn = std::function<bool()>;

  // initial_inputs: M x du (clipped into the bounds); initial_states: M x dx, row
  // 0 ignored (x_0 is `x0`), rows 1.. are the initial x_1..x_{M-1}.
  MultipleShootingNlp(const gp::DynamicsPredictor& model,
                      const ShootingObjective& objective, const Eigen::VectorXd& x0,
                      const Eigen::VectorXd& input_lower,
                      const Eigen::VectorXd& input_upper,
                      const Eigen::MatrixXd& initial_inputs,
                      const Eigen::MatrixXd& initial_states, StopFn stop = nullptr,
                      double feasibility_tolerance = 1e-6);

  // State constraints (safe_box.h) on every predicted next state, as 2 M dx
  // inequality rows after the dynamics rows: mean_j(z_i) +- margin sd_j(z_i)
  // against the box, with exact Jacobians (d sd = d var / (2 sd); sd is floored
  // at sqrt(kVarianceFloor)). Call before the solve.
  void SetSafeBox(SafeBox box) { safe_ = std::move(box); }

  // Optimistic exploration (OPAX): with beta > 0 the dynamics become
  //   x_{i+1} = mean(z_i) + beta sd(z_i) o eta_i,   eta_i in [-1, 1]^dx,
  // with (M - 1) dx hallucinated controls appended to w (after the states; the
  // objective does not depend on them directly) and sd the latent standard
  // deviation floored at sqrt(kVarianceFloor) (d sd = d var / (2 sd), 0 where
  // floored). initial_eta: (M - 1) x dx (clipped into [-1, 1]), or empty for 0.
  // Call before the solve.
  void SetOptimism(double beta, const Eigen::MatrixXd& initial_eta = {});

  int horizon() const { return horizon_; }
  int num_variables() const;
  int num_constraints() const;
  // Offsets in w of u_i (0 <= i < M), of x_i (1 <= i < M) and, with optimism,
  // of eta_i (0 <= i < M - 1).
  int InputOffset(int i) const { return i * du_; }
  int StateOffset(int i) const { return horizon_ * du_ + (i - 1) * dx_; }
  int EtaOffset(int i) const { return horizon_ * du_ + (horizon_ - 1 + i) * dx_; }
  // M x du inputs contained in a decision vector.
  Eigen::MatrixXd InputsOf(const Eigen::VectorXd& w) const;
  // (M - 1) x dx hallucinated controls in a decision vector (0 rows without
  // optimism).
  Eigen::MatrixXd EtaOf(const Eigen::VectorXd& w) const;
  // The decision vector of the initial guess.
  Eigen::VectorXd StartingPoint() const;

  // Best feasible point evaluated so far (empty if none) and its objective J.
  const Eigen::VectorXd& best_feasible() const { return best_feasible_; }
  double best_feasible_objective() const { return best_feasible_objective_; }
  // The last point the model was evaluated at (empty if none, or if the model was
  // not finite there): during a solve, in the StopFn, the newest iterate or trial
  // point.
  Eigen::VectorXd last_point() const {
    return cache_valid_ && cache_finite_ ? cached_w_ : Eigen::VectorXd();
  }
  // The point passed to finalize_solution (empty if never finalised).
  const Eigen::VectorXd& final_point() const { return final_point_; }
  int iterations() const { return iterations_; }
  // True if StopFn ended the solve.
  bool stopped() const { return stopped_; }
  // Number of Predict calls (new iterates evaluated).
  int evaluations() const { return evaluations_; }

  // Ipopt::TNLP.
  bool get_nlp_info(Ipopt::Index& n, Ipopt::Index& m, Ipopt::Index& nnz_jac_g,
                    Ipopt::Index& nnz_h_lag, IndexStyleEnum& index_style) override;
  bool get_bounds_info(Ipopt::Index n, Ipopt::Number* x_l, Ipopt::Number* x_u,
                       Ipopt::Index m, Ipopt::Number* g_l, Ipopt::Number* g_u) override;
  bool get_starting_point(Ipopt::Index n, bool init_x, Ipopt::Number* x, bool init_z,
                          Ipopt::Number* z_L, Ipopt::Number* z_U, Ipopt::Index m,
                          bool init_lambda, Ipopt::Number* lambda) override;
  bool eval_f(Ipopt::Index n, const Ipopt::Number* x, bool new_x,
              Ipopt::Number& obj_value) override;
  bool eval_grad_f(Ipopt::Index n, const Ipopt::Number* x, bool new_x,
                   Ipopt::Number* grad_f) override;
  bool eval_g(Ipopt::Index n, const Ipopt::Number* x, bool new_x, Ipopt::Index m,
              Ipopt::Number* g) override;
  bool eval_jac_g(Ipopt::Index n, const Ipopt::Number* x, bool new_x, Ipopt::Index m,
                  Ipopt::Index nele_jac, Ipopt::Index* iRow, Ipopt::Index* jCol,
                  Ipopt::Number* values) override;
  bool intermediate_callback(Ipopt::AlgorithmMode mode, Ipopt::Index iter,
                             Ipopt::Number obj_value, Ipopt::Number inf_pr,
                             Ipopt::Number inf_du, Ipopt::Number mu, Ipopt::Number d_norm,
                             Ipopt::Number regularization_size, Ipopt::Number alpha_du,
                             Ipopt::Number alpha_pr, Ipopt::Index ls_trials,
                             const Ipopt::IpoptData* ip_data,
                             Ipopt::IpoptCalculatedQuantities* ip_cq) override;
  void finalize_solution(Ipopt::SolverReturn status, Ipopt::Index n,
                         const Ipopt::Number* x, const Ipopt::Number* z_L,
                         const Ipopt::Number* z_U, Ipopt::Index m, const Ipopt::Number* g,
                         const Ipopt::Number* lambda, Ipopt::Number obj_value,
                         const Ipopt::IpoptData* ip_data,
                         Ipopt::IpoptCalculatedQuantities* ip_cq) override;

 private:
  // Makes the cache hold the values at w (n entries); false if the model
  // returned non-finite numbers there.
  bool Evaluate(const Ipopt::Number* w, bool new_x);

  const gp::DynamicsPredictor& model_;
  const ShootingObjective& objective_function_;
  const int dx_;
  const int du_;
  const int horizon_;
  const Eigen::VectorXd x0_;
  const Eigen::VectorXd lower_;
  const Eigen::VectorXd upper_;
  Eigen::MatrixXd initial_inputs_;
  Eigen::MatrixXd initial_states_;
  StopFn stop_;
  const double feasibility_tolerance_;
  SafeBox safe_;
  double beta_ = 0.0;  // > 0: optimistic dynamics
  Eigen::MatrixXd initial_eta_;
  int EtaRows() const { return beta_ > 0.0 ? horizon_ - 1 : 0; }

  // Cache of the last evaluated iterate.
  bool cache_valid_ = false;
  bool cache_finite_ = false;
  Eigen::VectorXd cached_w_;
  double objective_ = 0.0;
  Eigen::VectorXd gradient_;     // n
  Eigen::MatrixXd z_gradient_;   // M x (dx + du): d J / d z_i
  Eigen::VectorXd constraints_;  // m
  Eigen::VectorXd jacobian_;     // nnz, in the order of the sparsity structure
  Eigen::MatrixXd z_;            // M x (dx + du)
  Eigen::MatrixXd mean_;         // M x dx
  Eigen::MatrixXd variance_;     // M x dx
  std::vector<Eigen::MatrixXd> mean_jacobians_;
  std::vector<Eigen::MatrixXd> variance_jacobians_;

  Eigen::VectorXd best_feasible_;
  double best_feasible_objective_ = std::numeric_limits<double>::infinity();
  Eigen::VectorXd final_point_;
  int iterations_ = 0;
  bool stopped_ = false;
  int evaluations_ = 0;
};

}  // namespace excite::plan

#endif  // EXCITE_SERVER_PLAN_MULTIPLE_SHOOTING_NLP_H_
