#include "server/plan/multiple_shooting_nlp.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "server/plan/entropy_objective.h"  // kVarianceFloor

namespace excite::plan {
namespace {

// Ipopt treats |bound| >= 1e19 as infinite (nlp_lower/upper_bound_inf).
constexpr double kInfinity = 2e19;

}  // namespace

MultipleShootingNlp::MultipleShootingNlp(
    const gp::DynamicsPredictor& model, const ShootingObjective& objective,
    const Eigen::VectorXd& x0, const Eigen::VectorXd& input_lower,
    const Eigen::VectorXd& input_upper, const Eigen::MatrixXd& initial_inputs,
    const Eigen::MatrixXd& initial_states, StopFn stop, double feasibility_tolerance)
    : model_(model),
      objective_function_(objective),
      dx_(model.state_dim()),
      du_(model.input_dim()),
      horizon_(static_cast<int>(initial_inputs.rows())),
      x0_(x0),
      lower_(input_lower),
      upper_(input_upper),
      initial_inputs_(initial_inputs),
      initial_states_(initial_states),
      stop_(std::move(stop)),
      feasibility_tolerance_(feasibility_tolerance) {}

void MultipleShootingNlp::SetOptimism(double beta, const Eigen::MatrixXd& initial_eta) {
  beta_ = beta > 0.0 ? beta : 0.0;
  initial_eta_ = Eigen::MatrixXd::Zero(EtaRows(), dx_);
  if (initial_eta.rows() == initial_eta_.rows() && initial_eta.cols() == dx_) {
    initial_eta_ = initial_eta.cwiseMax(-1.0).cwiseMin(1.0);
  }
}

int MultipleShootingNlp::num_variables() const {
  return horizon_ * du_ + (horizon_ - 1 + EtaRows()) * dx_;
}

int MultipleShootingNlp::num_constraints() const {
  return (horizon_ - 1) * dx_ + (safe_.active() ? 2 * horizon_ * dx_ : 0);
}

Eigen::MatrixXd MultipleShootingNlp::InputsOf(const Eigen::VectorXd& w) const {
  Eigen::MatrixXd inputs(horizon_, du_);
  for (int i = 0; i < horizon_; ++i) {
    inputs.row(i) = w.segment(InputOffset(i), du_).transpose();
  }
  return inputs;
}

Eigen::MatrixXd MultipleShootingNlp::EtaOf(const Eigen::VectorXd& w) const {
  Eigen::MatrixXd eta(EtaRows(), dx_);
  for (int i = 0; i < EtaRows(); ++i)
    eta.row(i) = w.segment(EtaOffset(i), dx_).transpose();
  return eta;
}

Eigen::VectorXd MultipleShootingNlp::StartingPoint() const {
  Eigen::VectorXd w(num_variables());
  for (int i = 0; i < horizon_; ++i) {
    w.segment(InputOffset(i), du_) =
        initial_inputs_.row(i).transpose().cwiseMax(lower_).cwiseMin(upper_);
  }
  for (int i = 1; i < horizon_; ++i) {
    w.segment(StateOffset(i), dx_) = initial_states_.row(i).transpose();
  }
  for (int i = 0; i < EtaRows(); ++i) {
    w.segment(EtaOffset(i), dx_) = initial_eta_.row(i).transpose();
  }
  return w;
}

bool MultipleShootingNlp::get_nlp_info(Ipopt::Index& n, Ipopt::Index& m,
                                       Ipopt::Index& nnz_jac_g, Ipopt::Index& nnz_h_lag,
                                       IndexStyleEnum& index_style) {
  n = num_variables();
  m = num_constraints();
  nnz_jac_g = 0;
  for (int i = 0; i + 1 < horizon_; ++i) {
    nnz_jac_g += dx_ * (1 + du_ + (i >= 1 ? dx_ : 0) + (EtaRows() > 0 ? 1 : 0));
  }
  if (safe_.active()) {
    for (int i = 0; i < horizon_; ++i) nnz_jac_g += 2 * dx_ * (du_ + (i >= 1 ? dx_ : 0));
  }
  nnz_h_lag = 0;  // limited-memory Hessian
  index_style = C_STYLE;
  return true;
}

bool MultipleShootingNlp::get_bounds_info(Ipopt::Index n, Ipopt::Number* x_l,
                                          Ipopt::Number* x_u, Ipopt::Index m,
                                          Ipopt::Number* g_l, Ipopt::Number* g_u) {
  if (n != num_variables() || m != num_constraints()) return false;
  for (int i = 0; i < horizon_; ++i) {
    for (int l = 0; l < du_; ++l) {
      x_l[InputOffset(i) + l] = lower_(l);
      x_u[InputOffset(i) + l] = upper_(l);
    }
  }
  for (int k = horizon_ * du_; k < n; ++k) {
    const bool eta = EtaRows() > 0 && k >= EtaOffset(0);
    x_l[k] = eta ? -1.0 : -kInfinity;
    x_u[k] = eta ? 1.0 : kInfinity;
  }
  const int dynamics = (horizon_ - 1) * dx_;
  std::fill(g_l, g_l + dynamics, 0.0);
  std::fill(g_u, g_u + dynamics, 0.0);
  if (safe_.active()) {
    // Rows per (i, j): mean + margin sd <= upper, then mean - margin sd >= lower.
    for (int i = 0; i < horizon_; ++i) {
      for (int j = 0; j < dx_; ++j) {
        const int row = dynamics + 2 * (i * dx_ + j);
        g_l[row] = -kInfinity;
        g_u[row] = safe_.upper(j);
        g_l[row + 1] = safe_.lower(j);
        g_u[row + 1] = kInfinity;
      }
    }
  }
  return true;
}

bool MultipleShootingNlp::get_starting_point(Ipopt::Index n, bool init_x,
                                             Ipopt::Number* x, bool init_z,
                                             Ipopt::Number* /*z_L*/,
                                             Ipopt::Number* /*z_U*/, Ipopt::Index /*m*/,
                                             bool init_lambda,
                                             Ipopt::Number* /*lambda*/) {
  if (n != num_variables() || init_z || init_lambda) return false;
  if (init_x) Eigen::Map<Eigen::VectorXd>(x, n) = StartingPoint();
  return true;
}

bool MultipleShootingNlp::Evaluate(const Ipopt::Number* w_ptr, bool new_x) {
  const int n = num_variables();
  const Eigen::Map<const Eigen::VectorXd> w(w_ptr, n);
  if (cache_valid_ && (!new_x || w == cached_w_)) return cache_finite_;
  cached_w_ = w;
  cache_valid_ = true;
  cache_finite_ = false;
  ++evaluations_;

  const int zd = dx_ + du_;
  z_.resize(horizon_, zd);
  for (int i = 0; i < horizon_; ++i) {
    if (i == 0) {
      z_.row(i).head(dx_) = x0_.transpose();
    } else {
      z_.row(i).head(dx_) = w.segment(StateOffset(i), dx_).transpose();
    }
    z_.row(i).tail(du_) = w.segment(InputOffset(i), du_).transpose();
  }
  model_.Predict(z_, &mean_, &variance_, &mean_jacobians_, &variance_jacobians_);
  if (mean_.rows() != horizon_ || variance_.rows() != horizon_ ||
      static_cast<int>(mean_jacobians_.size()) != horizon_ ||
      static_cast<int>(variance_jacobians_.size()) != horizon_ || !mean_.allFinite() ||
      !variance_.allFinite()) {
    return false;
  }

  for (int i = 0; i < horizon_; ++i) {
    if (!mean_jacobians_[i].allFinite() || !variance_jacobians_[i].allFinite()) {
      return false;
    }
  }
  objective_ = objective_function_.Evaluate(z_, mean_, variance_, &mean_jacobians_,
                                            &variance_jacobians_, &z_gradient_);
  if (!std::isfinite(objective_) || !z_gradient_.allFinite()) return false;
  gradient_.setZero(n);
  for (int i = 0; i < horizon_; ++i) {
    gradient_.segment(InputOffset(i), du_) = z_gradient_.row(i).tail(du_).transpose();
    if (i >= 1) {
      gradient_.segment(StateOffset(i), dx_) = z_gradient_.row(i).head(dx_).transpose();
    }
  }

  const int m = num_constraints();
  constraints_.resize(m);
  // sd (and d sd / dz = d var / dz / (2 sd), 0 where floored) for the optimistic
  // dynamics and the safe box.
  Eigen::MatrixXd sd;
  if (safe_.active() || EtaRows() > 0)
    sd = variance_.cwiseMax(kVarianceFloor).cwiseSqrt();
  const auto dsd_scale = [&](int i, int j) {
    return variance_(i, j) > kVarianceFloor ? 0.5 / sd(i, j) : 0.0;
  };
  for (int i = 0; i + 1 < horizon_; ++i) {
    constraints_.segment(i * dx_, dx_) =
        w.segment(StateOffset(i + 1), dx_) - mean_.row(i).transpose();
    if (EtaRows() > 0) {
      constraints_.segment(i * dx_, dx_) -=
          beta_ * sd.row(i).transpose().cwiseProduct(w.segment(EtaOffset(i), dx_));
    }
  }
  const int dynamics = (horizon_ - 1) * dx_;
  if (safe_.active()) {
    for (int i = 0; i < horizon_; ++i) {
      for (int j = 0; j < dx_; ++j) {
        const int row = dynamics + 2 * (i * dx_ + j);
        constraints_(row) = mean_(i, j) + safe_.margin * sd(i, j);
        constraints_(row + 1) = mean_(i, j) - safe_.margin * sd(i, j);
      }
    }
  }

  // Values in the order of the structure written by eval_jac_g.
  std::vector<double> values;
  values.reserve(static_cast<size_t>(m) * (1 + du_ + dx_));
  for (int i = 0; i + 1 < horizon_; ++i) {
    for (int r = 0; r < dx_; ++r) {
      // d (next state row r) / d z_i: the mean's, plus the hallucination's.
      Eigen::RowVectorXd d = mean_jacobians_[i].row(r);
      if (EtaRows() > 0) {
        d +=
            beta_ * w(EtaOffset(i) + r) * dsd_scale(i, r) * variance_jacobians_[i].row(r);
      }
      values.push_back(1.0);
      if (i >= 1) {
        for (int l = 0; l < dx_; ++l) values.push_back(-d(l));
      }
      for (int l = 0; l < du_; ++l) values.push_back(-d(dx_ + l));
      if (EtaRows() > 0) values.push_back(-beta_ * sd(i, r));
    }
  }
  if (safe_.active()) {
    for (int i = 0; i < horizon_; ++i) {
      for (int j = 0; j < dx_; ++j) {
        for (const double sign : {1.0, -1.0}) {
          const Eigen::RowVectorXd d =
              mean_jacobians_[i].row(j) +
              sign * safe_.margin * dsd_scale(i, j) * variance_jacobians_[i].row(j);
          if (i >= 1) {
            for (int l = 0; l < dx_; ++l) values.push_back(d(l));
          }
          for (int l = 0; l < du_; ++l) values.push_back(d(dx_ + l));
        }
      }
    }
  }
  jacobian_ = Eigen::Map<const Eigen::VectorXd>(values.data(),
                                                static_cast<Eigen::Index>(values.size()));
  cache_finite_ = true;

  double violation =
      dynamics > 0 ? constraints_.head(dynamics).cwiseAbs().maxCoeff() : 0.0;
  if (safe_.active()) {
    violation = std::max(violation, SafeBoxViolation(safe_, mean_, variance_));
  }
  if (violation <= feasibility_tolerance_ && objective_ < best_feasible_objective_) {
    best_feasible_objective_ = objective_;
    best_feasible_ = w;
  }
  return true;
}

bool MultipleShootingNlp::eval_f(Ipopt::Index n, const Ipopt::Number* x, bool new_x,
                                 Ipopt::Number& obj_value) {
  if (n != num_variables() || !Evaluate(x, new_x)) return false;
  obj_value = objective_;
  return true;
}

bool MultipleShootingNlp::eval_grad_f(Ipopt::Index n, const Ipopt::Number* x, bool new_x,
                                      Ipopt::Number* grad_f) {
  if (n != num_variables() || !Evaluate(x, new_x)) return false;
  Eigen::Map<Eigen::VectorXd>(grad_f, n) = gradient_;
  return true;
}

bool MultipleShootingNlp::eval_g(Ipopt::Index n, const Ipopt::Number* x, bool new_x,
                                 Ipopt::Index m, Ipopt::Number* g) {
  if (n != num_variables() || m != num_constraints()) return false;
  if (m == 0) return true;
  if (!Evaluate(x, new_x)) return false;
  Eigen::Map<Eigen::VectorXd>(g, m) = constraints_;
  return true;
}

bool MultipleShootingNlp::eval_jac_g(Ipopt::Index n, const Ipopt::Number* x, bool new_x,
                                     Ipopt::Index m, Ipopt::Index nele_jac,
                                     Ipopt::Index* iRow, Ipopt::Index* jCol,
                                     Ipopt::Number* values) {
  if (n != num_variables() || m != num_constraints()) return false;
  if (values == nullptr) {
    Ipopt::Index k = 0;
    const auto add = [&](int row, int column) {
      iRow[k] = row;
      jCol[k++] = column;
    };
    // The columns of z_i = (x_i, u_i) in w (x_0 is fixed: no columns).
    const auto add_point = [&](int row, int i) {
      if (i >= 1) {
        for (int l = 0; l < dx_; ++l) add(row, StateOffset(i) + l);
      }
      for (int l = 0; l < du_; ++l) add(row, InputOffset(i) + l);
    };
    for (int i = 0; i + 1 < horizon_; ++i) {
      for (int r = 0; r < dx_; ++r) {
        const int row = i * dx_ + r;
        add(row, StateOffset(i + 1) + r);
        add_point(row, i);
        if (EtaRows() > 0) add(row, EtaOffset(i) + r);
      }
    }
    if (safe_.active()) {
      const int dynamics = (horizon_ - 1) * dx_;
      for (int i = 0; i < horizon_; ++i) {
        for (int row = dynamics + 2 * i * dx_; row < dynamics + 2 * (i + 1) * dx_;
             ++row) {
          add_point(row, i);
        }
      }
    }
    return k == nele_jac;
  }
  if (m == 0) return true;
  if (!Evaluate(x, new_x) || jacobian_.size() != nele_jac) return false;
  Eigen::Map<Eigen::VectorXd>(values, nele_jac) = jacobian_;
  return true;
}

bool MultipleShootingNlp::intermediate_callback(
    Ipopt::AlgorithmMode /*mode*/, Ipopt::Index iter, Ipopt::Number /*obj_value*/,
    Ipopt::Number /*inf_pr*/, Ipopt::Number /*inf_du*/, Ipopt::Number /*mu*/,
    Ipopt::Number /*d_norm*/, Ipopt::Number /*regularization_size*/,
    Ipopt::Number /*alpha_du*/, Ipopt::Number /*alpha_pr*/, Ipopt::Index /*ls_trials*/,
    const Ipopt::IpoptData* /*ip_data*/, Ipopt::IpoptCalculatedQuantities* /*ip_cq*/) {
  iterations_ = std::max<int>(iterations_, iter);
  if (stop_ && stop_()) {
    stopped_ = true;
    return false;
  }
  return true;
}

void MultipleShootingNlp::finalize_solution(
    Ipopt::SolverReturn /*status*/, Ipopt::Index n, const Ipopt::Number* x,
    const Ipopt::Number* /*z_L*/, const Ipopt::Number* /*z_U*/, Ipopt::Index /*m*/,
    const Ipopt::Number* /*g*/, const Ipopt::Number* /*lambda*/,
    Ipopt::Number /*obj_value*/, const Ipopt::IpoptData* /*ip_data*/,
    Ipopt::IpoptCalculatedQuantities* /*ip_cq*/) {
  if (n == num_variables() && x != nullptr) {
    final_point_ = Eigen::Map<const Eigen::VectorXd>(x, n);
  }
}

}  // namespace excite::plan
