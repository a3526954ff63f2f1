#ifndef EXCITE_SERVER_GP_DYNAMICS_PREDICTOR_H_
#define EXCITE_SERVER_GP_DYNAMICS_PREDICTOR_H_

#include <Eigen/Dense>
#include <memory>
#include <vector>

namespace excite::gp {

// What a planner needs from a probabilistic one-step dynamics model
// x_{k+1} ~ N(mean(z), variance(z)) with z = (x_k, u_k): implemented by
// DynamicsModel, and by analytic stand-ins in tests.
class DynamicsPredictor {
 public:
  virtual ~DynamicsPredictor() = default;

  virtual int state_dim() const = 0;
  virtual int input_dim() const = 0;
  int z_dim() const { return state_dim() + input_dim(); }

  // For m points z (m x z_dim, one per row): the predicted next state `mean`
  // (m x state_dim) and the latent variance of each output `variance`
  // (m x state_dim), in the units of the data. Null outputs are not computed
  // (for a GP the mean alone needs no triangular solve). If the Jacobian outputs
  // are not null they are resized to m entries, each state_dim x z_dim:
  // (*mean_jacobians)[i](j, l) = d mean(i, j) / d z(i, l), same for variance.
  // Thread-safety: const calls may run concurrently.
  virtual void Predict(const Eigen::MatrixXd& z, Eigen::MatrixXd* mean,
                       Eigen::MatrixXd* variance,
                       std::vector<Eigen::MatrixXd>* mean_jacobians,
                       std::vector<Eigen::MatrixXd>* variance_jacobians) const = 0;

  // Joint posterior covariances, for objectives that value a set of points
  // together (mutual information, variance reduction over a region). Optional:
  // the defaults say "not supported" (PreparePoints returns null).
  //
  // A point set with what depends only on the model and the set computed once
  // (for a GP: L \ K(X, z) per output, O(m n^2)). Valid while the model is not
  // changed.
  class PreparedPoints {
   public:
    virtual ~PreparedPoints() = default;
  };
  // z: m x z_dim. Null if the model has no joint covariances.
  virtual std::unique_ptr<PreparedPoints> PreparePoints(const Eigen::MatrixXd& z) const {
    (void)z;
    return nullptr;
  }
  // Per output j, the latent posterior covariance between the points of a and b
  // (rows(a) x rows(b), data units squared). Both from this model's PreparePoints.
  virtual std::vector<Eigen::MatrixXd> PosteriorCovariance(
      const PreparedPoints& a, const PreparedPoints& b) const {
    (void)a;
    (void)b;
    return {};
  }
  // Per point of a and output j, the latent posterior variance (rows(a) x
  // state_dim, data units squared): the diagonal of PosteriorCovariance(a, a)
  // at O(m n) instead of O(m^2 n).
  virtual Eigen::MatrixXd PosteriorVariance(const PreparedPoints& a) const {
    (void)a;
    return {};
  }
  // Gradient w.r.t. the points of a (every b held fixed) of
  // sum_t sum_j sum_ik terms[t].weights[j](i, k) cov_j(a_i, b_t,k): rows(a) x
  // z_dim. For a weight on cov(a, a) with a symmetric weight matrix, pass b = a
  // and twice the weights. Terms are summed before the work that they share.
  struct CovarianceTerm {
    const PreparedPoints* b;
    const std::vector<Eigen::MatrixXd>* weights;  // per output: rows(a) x rows(b)
  };
  virtual Eigen::MatrixXd PosteriorCovarianceGradient(
      const PreparedPoints& a, const std::vector<CovarianceTerm>& terms) const {
    (void)a;
    (void)terms;
    return {};
  }
  // Noise variance of each output's observations (state_dim, data units): what a
  // new sample's target is measured with. Empty if unknown.
  virtual Eigen::VectorXd ObservationNoiseVariances() const { return {}; }
};

}  // namespace excite::gp

#endif  // EXCITE_SERVER_GP_DYNAMICS_PREDICTOR_H_
