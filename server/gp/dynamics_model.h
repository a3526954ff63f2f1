#ifndef EXCITE_SERVER_GP_DYNAMICS_MODEL_H_
#define EXCITE_SERVER_GP_DYNAMICS_MODEL_H_

#include <Eigen/Dense>
#include <functional>
#include <memory>
#include <optional>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "model_file/model_data.h"
#include "server/gp/dynamics_predictor.h"
#include "server/gp/hyperparameter_fit.h"
#include "server/gp/hyperparameters.h"
#include "server/gp/sparse_gp_model.h"

namespace excite::gp {

enum class Target {
  kDelta,  // each GP regresses x_{k+1} - x_k
  kNext,   // each GP regresses x_{k+1}
};

// Each output's prior mean (see DynamicsModel).
enum class PriorMean {
  kConstant,  // the mean of all targets, refreshed at every AddSamples()
  kLinear,    // affine in the normalised kernel inputs, fitted at every Build
};

// Everything that configures a DynamicsModel, in the units of the data.
struct DynamicsModelOptions {
  int state_dim = 0;
  int input_dim = 0;
  Target target = Target::kDelta;
  // State dimensions that are angles (each once, in [0, state_dim); needs
  // kDelta): the GPs see (sin, cos) of each (InputFeatures), so hyperparameters
  // have kernel_inputs() lengthscales, and regress the difference wrapped to
  // (-pi, pi]. The mean stays continuous: x + the predicted difference, so a
  // state and the same state plus 2 pi predict the same up to that 2 pi.
  std::vector<int> angle_dims;
  PriorMean prior_mean = PriorMean::kConstant;
  // Known measurement noise variance of the state (> 0).
  double measurement_noise_variance = 0.0;
  // Fit the target's noise variance (floor: measurement_noise_variance). If false
  // it is fixed at measurement_noise_variance for kNext and twice that for kDelta
  // (both measurements of a difference are noisy).
  bool fit_noise = true;
  // Fit kernel hyperparameters by ML-II; if false, `fixed` (state_dim entries,
  // each with kernel_inputs() lengthscales) is used as is.
  // (Implementation note: `fixed` is in data units and used as is *including* its
  // noise_variance; fit_noise is then ignored.)
  bool fit_kernel = true;
  std::vector<Hyperparameters> fixed;
  FitOptions fit;
  // Threads for Refit(): outputs are fitted independently, on up to this many
  // std::threads (only when there are >= 2 outputs and >= 64 samples), each taking
  // the next output not yet taken. Results do not depend on it.
  int fit_threads = 2;
  // If set, the third and further fit threads each run their share only through
  // it: it runs the work it is given if a worker of the process is free (the
  // caller's own thread and the second always fit). Null: all fit_threads run.
  std::function<void(const std::function<void()>& work)> run_if_worker_free;
  // Centre and half-width of each dimension of z used to normalise GP inputs
  // (z_dim entries each). A non-finite entry means "from the data at the first
  // fit". Typically from the region of interest and the input bounds.
  // (Implementation: empty vectors mean all non-finite. From the data: centre =
  // mean, half-width = max(sqrt(3) * std, 1e-3), i.e. the half-width of a uniform
  // distribution with that std. Prefer finite values: a dimension that barely
  // varies in the first samples gets a tiny half-width for good.)
  Eigen::VectorXd input_center;
  Eigen::VectorXd input_half_width;
  // Long sessions: when a Refit() or Rebuild() finds more than this many samples
  // (or AddSamples() passes it on a fitted model: then with the current
  // hyperparameters), each output becomes a sparse GP (SparseGpModel, inducing points
  // from all the data) whose hyperparameters are fitted by ML-II on a strided subset of
  // at most `sparse_fit_samples` samples, so neither time nor memory per step grows as
  // n^2 (a refit costs at most an exact fit of sparse_fit_samples). 0: always exact.
  int sparse_above = 0;
  // Fewer samples than this fitted lengthscales too short on the pendulum (a subset of
  // 300 of 700 samples: one-step RMSE 0.120 against 0.107 from all; README).
  int sparse_fit_samples = 1000;
  SparseGpOptions sparse;
};

// One independent GP (squared-exponential ARD kernel) per state dimension on
// inputs z = (x, u): exact, or sparse above options.sparse_above samples. Each output's
// prior mean is either the mean of all its targets so far (kConstant), refreshed at
// every AddSamples(), or (kLinear) the least-squares affine fit of its targets on the
// normalised kernel inputs over the samples of the last fit: on all samples at a
// Refit(), on the first sample_count() - samples_since_fit() at a Rebuild(), and fixed
// in between. Both make the model a function of the data, the hyperparameters and
// samples_since_fit(), so a model rebuilt from the same data and hyperparameters (after
// a restart or an import) predicts the same. kLinear needs more than 2 (kernel_inputs()
// + 1) samples for its fit (fewer would fit the noise); below that it is constant, the
// mean of those samples. For the fit, inputs are normalised with the
// fixed centre/half-width and each output is divided by its targets' standard deviation
// at that Refit(); the model in data units does not depend on either. Not thread-safe for
// mutation; const methods may run concurrently.
class DynamicsModel final : public DynamicsPredictor {
 public:
  static absl::StatusOr<DynamicsModel> Create(DynamicsModelOptions options);

  int state_dim() const override;
  int input_dim() const override;
  // Inputs of each GP's kernel: state_dim + input_dim + one per angle.
  int kernel_inputs() const;

  // Appends transitions (rows of the three matrices) and refreshes the prior
  // means. Before the first Refit() the data is only kept; after it each sample
  // costs O(n^2) per output (Cholesky row append), plus two O(n^2) solves per
  // output for the new prior mean (sparse: O(M^2), see SparseGpModel);
  // hyperparameters and the exact/sparse choice unchanged. INVALID_ARGUMENT
  // when CheckSamples() fails (nothing is added then).
  absl::Status AddSamples(const Eigen::MatrixXd& states, const Eigen::MatrixXd& inputs,
                          const Eigen::MatrixXd& next_states);

  // Whether AddSamples() would accept these transitions: shapes, finite values,
  // and finite derived numbers the model computes from all its data with them
  // (targets, their mean and spread, the inputs' spread). INVALID_ARGUMENT naming
  // the first offending row. O((n + m) (state_dim + input_dim)); changes nothing,
  // so a caller can check before it stores anything.
  absl::Status CheckSamples(const Eigen::MatrixXd& states, const Eigen::MatrixXd& inputs,
                            const Eigen::MatrixXd& next_states) const;

  // Refreshes the output standardisation, fits hyperparameters (if enabled,
  // warm-started from the previous fit) and refactorises: O(n^3) per output.
  // The summary's wall_time_ms is the elapsed time of the whole call.
  // `stop` (see FitStopFn) ends the fit early with the best hyperparameters seen
  // (summary.stopped): the model is then valid, but samples_since_fit() is kept,
  // so the next Refit() continues from that point instead of being skipped.
  // FAILED_PRECONDITION with fewer than 2 samples.
  absl::StatusOr<FitSummary> Refit(const FitStopFn& stop = nullptr);

  // Seeds the warm start of the next Refit() with `data_units` (one per output,
  // in data units, e.g. hyperparameters() saved before a restart): that fit
  // starts from them as if they came from a previous fit, and until then
  // hyperparameters() returns them (fitted() stays false). The data-driven
  // default starts are rerun only once the data grows by
  // fit.default_start_growth from the sample count at this call, so call it
  // after adding the restored samples. `fitted_samples`: how many of the
  // samples they were fitted on (clamped to [0, sample_count()]; 0 if unknown),
  // so samples_since_fit() is what it was when they were saved. Ignored by
  // Refit() when fit_kernel is off. INVALID_ARGUMENT on a wrong count or shape
  // or a non-positive or non-finite value (nothing changes then);
  // FAILED_PRECONDITION once fitted().
  absl::Status SeedWarmStart(std::vector<Hyperparameters> data_units,
                             int fitted_samples = 0);

  // Makes the model usable (fitted() true) with hyperparameters() as they are,
  // without fitting: O(n^3) per output. For a model seeded by SeedWarmStart()
  // whose fit is still current (no refit due), so it predicts exactly as before
  // the restart. samples_since_fit() is kept. FAILED_PRECONDITION without
  // hyperparameters or with fewer than 2 samples.
  absl::Status Rebuild();

  // The model's data, options and hyperparameters without its fitted GPs
  // (fitted() false): Refit() or Rebuild() of the copy gives exactly the model
  // they would give here, so a caller can fit beside a model that still answers.
  // O(n (state_dim + input_dim)).
  DynamicsModel CopyData() const;

  int sample_count() const;
  // Samples added since the last Refit().
  int samples_since_fit() const;
  // True once Refit() succeeded: Predict() is valid.
  bool fitted() const;

  // Upper estimate, in bytes, of the memory of a model of these dimensions with
  // `samples` samples at its peak: what it keeps (per output the Cholesky factor
  // with its growth room, the kernel matrix cached by the last factorisation, the
  // data) plus what a Refit() allocates while it runs on `fit_threads` threads
  // (five n x n matrices per output being fitted). For memory budgets; compared
  // with a real server's peak resident memory in bench/load/session_memory.py.
  // With sparse_above > 0 and more samples than that: the sparse models at
  // `max_inducing` points, the data, and the fit of at most sparse_fit_samples.
  static int64_t PeakBytes(int64_t samples, int state_dim, int input_dim, int fit_threads,
                           int sparse_above = 0, int max_inducing = 0,
                           int sparse_fit_samples = 0);

  // See DynamicsPredictor. Requires fitted() and z.cols() == z_dim() (a
  // precondition, not checked by status: if violated, outputs are resized and
  // filled with NaN). Costs O(m n^2) per output
  // (O(m n (n + z_dim)) with Jacobians).
  void Predict(const Eigen::MatrixXd& z, Eigen::MatrixXd* mean, Eigen::MatrixXd* variance,
               std::vector<Eigen::MatrixXd>* mean_jacobians,
               std::vector<Eigen::MatrixXd>* variance_jacobians) const override;

  // Joint posterior covariances (see DynamicsPredictor); not offered by the
  // sparse models (PreparePoints returns null). Require fitted(); a set
  // prepared before a model change must not be used after it. PreparePoints costs
  // O(m n^2) per output, PosteriorCovariance O(m_a m_b n), the gradient
  // O(m_a n^2 + m_a m_b n) per output.
  std::unique_ptr<PreparedPoints> PreparePoints(const Eigen::MatrixXd& z) const override;
  std::vector<Eigen::MatrixXd> PosteriorCovariance(
      const PreparedPoints& a, const PreparedPoints& b) const override;
  Eigen::MatrixXd PosteriorVariance(const PreparedPoints& a) const override;
  Eigen::MatrixXd PosteriorCovarianceGradient(
      const PreparedPoints& a, const std::vector<CovarianceTerm>& terms) const override;
  Eigen::VectorXd ObservationNoiseVariances() const override { return noise_variances(); }

  // Prior mean of each output's target (data units): kConstant, the mean of all
  // targets so far (0 before any data); kLinear, its value at the centre of the
  // input normalisation (0 before the first fit).
  Eigen::VectorXd prior_means() const;
  // kLinear: the prior mean's slope along each kernel input, in data units
  // (state_dim x kernel_inputs()); empty for kConstant or before the first fit.
  Eigen::MatrixXd prior_mean_slopes() const;
  // Noise variance of each output's target (data units), for "latent + noise".
  Eigen::VectorXd noise_variances() const;
  // Per output, in data units; empty before the first Refit() unless seeded
  // by SeedWarmStart().
  std::vector<Hyperparameters> hyperparameters() const;
  // Per output: log p(targets | inputs, hyperparameters) in data units, with the
  // prior mean prior_means() (the normalised LML minus n log(output scale));
  // for a sparse model, that of the exact GP on the subset of sparse_fit_samples
  // (evenly spread) at the last Refit() or Rebuild(). Empty before the first
  // Refit().
  std::vector<double> log_marginal_likelihoods() const;
  // Per output, what the last fit left at a bound of options.fit (HitBounds);
  // empty unless fitted with fit_kernel.
  std::vector<BoundHits> bound_hits() const;
  // What Predict depends on, for a model file (model_file/model_data.h): the
  // normalisation, prior means, output scales, noise variances and, per output,
  // the GP's points, weights and factors. nullopt unless fitted().
  std::optional<model::ModelData> ExportModel() const;
  // True when the outputs are sparse GPs.
  bool sparse() const;
  // Inducing points of each output (empty unless sparse()).
  std::vector<int> inducing_counts() const;

  DynamicsModel(DynamicsModel&&) noexcept;
  DynamicsModel& operator=(DynamicsModel&&) noexcept;
  ~DynamicsModel() override;

 private:
  struct State;
  explicit DynamicsModel(std::unique_ptr<State> state);
  // Refit() (fit_hyperparameters) or Rebuild().
  absl::StatusOr<FitSummary> Build(bool fit_hyperparameters, const FitStopFn& stop);
  std::unique_ptr<State> state_;
};

}  // namespace excite::gp

#endif  // EXCITE_SERVER_GP_DYNAMICS_MODEL_H_
