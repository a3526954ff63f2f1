#include "server/gp/dynamics_model.h"

#include <Eigen/Dense>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <thread>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "common/angles.h"
#include "server/gp/flush_denormals.h"
#include "server/gp/gp_model.h"
#include "server/gp/hyperparameter_fit.h"
#include "server/gp/hyperparameters.h"
#include "server/gp/input_features.h"
#include "server/gp/sparse_gp_model.h"

namespace excite::gp {
namespace {

constexpr double kMinDataHalfWidth = 1e-3;
constexpr int kMinSamplesForThreads = 64;

uint64_t SplitMix64(uint64_t x) {
  x += 0x9E3779B97F4A7C15ULL;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ULL;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBULL;
  return x ^ (x >> 31);
}

bool PositiveFinite(double v) { return std::isfinite(v) && v > 0.0; }

// Data units <-> normalised units of one output.
Hyperparameters ToNormalised(const Hyperparameters& h, const Eigen::VectorXd& half_width,
                             double out_std) {
  const double s2 = out_std * out_std;
  Hyperparameters n;
  n.signal_variance = h.signal_variance / s2;
  n.lengthscales = h.lengthscales.cwiseQuotient(half_width);
  n.noise_variance = h.noise_variance / s2;
  return n;
}

Hyperparameters ToData(const Hyperparameters& h, const Eigen::VectorXd& half_width,
                       double out_std) {
  const double s2 = out_std * out_std;
  Hyperparameters d;
  d.signal_variance = h.signal_variance * s2;
  d.lengthscales = h.lengthscales.cwiseProduct(half_width);
  d.noise_variance = h.noise_variance * s2;
  return d;
}

// A prior mean: intercept (one per output) + slopes (outputs x features) . the
// normalised features.
struct PriorFit {
  Eigen::VectorXd intercept;
  Eigen::MatrixXd slopes;
};

// The least-squares affine fit of the targets (n x outputs) on the normalised
// features zn of the first `count` samples (the minimum-norm one if they are
// collinear); constant (their mean) while count <= 2 (features + 1), where it
// would follow the noise.
PriorFit FitLinearPriorMean(const Eigen::MatrixXd& zn, const Eigen::MatrixXd& targets,
                            int count) {
  const Eigen::Index p = zn.cols() + 1;
  PriorFit fit{targets.topRows(count).colwise().mean().transpose(),
               Eigen::MatrixXd::Zero(targets.cols(), p - 1)};
  if (count <= 2 * p) return fit;
  Eigen::MatrixXd design(count, p);
  design << Eigen::VectorXd::Ones(count), zn.topRows(count);
  const Eigen::MatrixXd coefficients =
      design.completeOrthogonalDecomposition().solve(targets.topRows(count));
  fit.intercept = coefficients.row(0).transpose();
  fit.slopes = coefficients.bottomRows(p - 1).transpose();
  return fit;
}

}  // namespace

// Everything of a model but its fitted GPs: what a refit reads (State adds the GPs).
struct UnfittedState {
  DynamicsModelOptions options;
  int state_dim = 0;
  int input_dim = 0;
  int z_dim = 0;
  InputFeatures features{0, {}};
  // All data, in data units: the features of the inputs z = (x, u)
  // (InputFeatures) and the targets (delta, angles wrapped, or next).
  Eigen::MatrixXd z;
  Eigen::MatrixXd targets;
  int samples_since_fit = 0;
  int refits = 0;
  // Sample count at the last Refit() that ran the data-driven default start.
  int default_start_n = 0;
  bool fitted = false;
  // Input normalisation (resolved at the first Refit()).
  bool normalisation_resolved = false;
  Eigen::VectorXd center;
  Eigen::VectorXd half_width;
  // Prior mean of each output: kConstant, the mean of all targets, refreshed at
  // every AddSamples() so that it depends on the data only; kLinear, the
  // intercept at the normalisation's centre, with prior_slopes (state_dim x
  // kernel inputs, on the normalised features; zero for kConstant) from Build.
  Eigen::VectorXd prior_mean;
  Eigen::MatrixXd prior_slopes;
  // Output scale of the fit's normalised units (refreshed at every Refit()); the
  // model in data units does not depend on it.
  Eigen::VectorXd out_std;
  bool sparse = false;
  std::vector<Hyperparameters> data_hyperparameters;

  int n() const { return static_cast<int>(z.rows()); }
  // Noise variance of a target when it is not fitted (data units).
  double FixedNoise() const {
    return options.target == Target::kDelta ? 2.0 * options.measurement_noise_variance
                                            : options.measurement_noise_variance;
  }
  bool linear_mean() const { return options.prior_mean == PriorMean::kLinear; }
  // Targets of output j centred on a constant prior mean and divided by `scale`.
  Eigen::VectorXd StandardisedTargets(int j, double scale) const {
    return (targets.col(j).array() - prior_mean(j)) / scale;
  }
  // All targets minus a prior mean (zn: the normalised features of all data).
  Eigen::MatrixXd Residuals(const Eigen::MatrixXd& zn, const PriorFit& prior) const {
    Eigen::MatrixXd r = targets.rowwise() - prior.intercept.transpose();
    if (linear_mean()) r -= zn * prior.slopes.transpose();
    return r;
  }
  Eigen::MatrixXd NormaliseFeatures(const Eigen::MatrixXd& f) const {
    return (f.rowwise() - center.transpose()) * half_width.cwiseInverse().asDiagonal();
  }
  // Normalised features of inputs z (m x z_dim).
  Eigen::MatrixXd Normalise(const Eigen::MatrixXd& inputs) const {
    return NormaliseFeatures(features.Map(inputs));
  }
  // The regression targets of transitions.
  Eigen::MatrixXd Targets(const Eigen::MatrixXd& states,
                          const Eigen::MatrixXd& next_states) const {
    if (options.target == Target::kNext) return next_states;
    Eigen::MatrixXd delta = next_states - states;
    for (int a : options.angle_dims) delta.col(a) = delta.col(a).unaryExpr(&WrapAngle);
    return delta;
  }
};

struct DynamicsModel::State : UnfittedState {
  // Per output: exact GPs, or (sparse) sparse GPs with the LML of the exact GP
  // on the fit's subset.
  std::vector<GpModel> gps;
  std::vector<SparseGpModel> sparse_gps;
  std::vector<double> sparse_fit_lml;
};

absl::StatusOr<DynamicsModel> DynamicsModel::Create(DynamicsModelOptions options) {
  if (options.state_dim < 1 || options.input_dim < 0) {
    return absl::InvalidArgumentError("state_dim must be >= 1 and input_dim >= 0");
  }
  const int z_dim = options.state_dim + options.input_dim;
  if (!PositiveFinite(options.measurement_noise_variance)) {
    return absl::InvalidArgumentError(
        "measurement_noise_variance must be finite and positive");
  }
  for (Eigen::VectorXd* v : {&options.input_center, &options.input_half_width}) {
    if (v->size() == 0) {
      *v = Eigen::VectorXd::Constant(z_dim, std::numeric_limits<double>::quiet_NaN());
    } else if (v->size() != z_dim) {
      return absl::InvalidArgumentError(absl::StrCat(
          "input_center and input_half_width need z_dim = ", z_dim, " entries"));
    }
  }
  for (int i = 0; i < z_dim; ++i) {
    const double h = options.input_half_width(i);
    if (std::isfinite(h) && !(h > 0.0)) {
      return absl::InvalidArgumentError("input_half_width entries must be positive");
    }
  }
  std::vector<int> angles = options.angle_dims;
  std::sort(angles.begin(), angles.end());
  if (std::adjacent_find(angles.begin(), angles.end()) != angles.end() ||
      (!angles.empty() && (angles.front() < 0 || angles.back() >= options.state_dim))) {
    return absl::InvalidArgumentError(
        "angle_dims must name state dimensions in [0, state_dim), each once");
  }
  if (!angles.empty() && options.target != Target::kDelta) {
    return absl::InvalidArgumentError(
        "angle_dims need the delta target: a next angle is only known up to 2 pi");
  }
  InputFeatures features(z_dim, angles);
  options.input_center = features.MapCenter(options.input_center);
  options.input_half_width = features.MapHalfWidth(options.input_half_width);
  const int kernel_inputs = features.feature_dim();
  if (!options.fit_kernel) {
    if (static_cast<int>(options.fixed.size()) != options.state_dim) {
      return absl::InvalidArgumentError("fit_kernel=false needs state_dim fixed entries");
    }
    for (const Hyperparameters& h : options.fixed) {
      if (h.lengthscales.size() != kernel_inputs || !PositiveFinite(h.signal_variance) ||
          !PositiveFinite(h.noise_variance) || !h.lengthscales.allFinite() ||
          !(h.lengthscales.array() > 0.0).all()) {
        return absl::InvalidArgumentError(
            "fixed hyperparameters need kernel_inputs positive lengthscales and positive "
            "variances");
      }
    }
  }
  if (options.fit_threads < 1) options.fit_threads = 1;
  if (options.sparse_above < 0 || options.sparse_fit_samples < 2 ||
      options.sparse.max_inducing < 1 || !(options.sparse.inducing_tolerance > 0.0) ||
      !std::isfinite(options.sparse.inducing_tolerance)) {
    return absl::InvalidArgumentError(
        "sparse_above must be >= 0, sparse_fit_samples >= 2, sparse.max_inducing >= 1 "
        "and "
        "sparse.inducing_tolerance finite and > 0");
  }
  auto state = std::make_unique<State>();
  state->state_dim = options.state_dim;
  state->input_dim = options.input_dim;
  state->z_dim = z_dim;
  state->features = std::move(features);
  state->z.resize(0, kernel_inputs);
  state->targets.resize(0, options.state_dim);
  state->prior_mean = Eigen::VectorXd::Zero(options.state_dim);
  state->prior_slopes = Eigen::MatrixXd::Zero(options.state_dim, kernel_inputs);
  state->options = std::move(options);
  return DynamicsModel(std::move(state));
}

DynamicsModel::DynamicsModel(std::unique_ptr<State> state) : state_(std::move(state)) {}
DynamicsModel::DynamicsModel(DynamicsModel&&) noexcept = default;
DynamicsModel& DynamicsModel::operator=(DynamicsModel&&) noexcept = default;
DynamicsModel::~DynamicsModel() = default;

DynamicsModel DynamicsModel::CopyData() const {
  auto copy = std::make_unique<State>();
  static_cast<UnfittedState&>(*copy) = *state_;
  copy->fitted = false;
  return DynamicsModel(std::move(copy));
}

int DynamicsModel::state_dim() const { return state_->state_dim; }
int DynamicsModel::input_dim() const { return state_->input_dim; }
int DynamicsModel::sample_count() const { return state_->n(); }
int DynamicsModel::kernel_inputs() const { return state_->features.feature_dim(); }

int64_t DynamicsModel::PeakBytes(int64_t samples, int state_dim, int input_dim,
                                 int fit_threads, int sparse_above, int max_inducing,
                                 int sparse_fit_samples) {
  const int64_t n = std::max<int64_t>(samples, 0);
  const int64_t z_dim = int64_t{state_dim} + input_dim;
  if (sparse_above > 0 && n > sparse_above) {
    // Per output: the sparse model (its factors, inputs and scaled inputs,
    // targets) twice, as a Refit() builds the new one beside the old, with its
    // workspace; and the exact GPs of the subset while they are fitted.
    const int64_t model =
        SparseGpModel::FactorBytes(max_inducing, static_cast<int>(z_dim)) +
        static_cast<int64_t>(sizeof(double)) * n * (2 * z_dim + 1);
    const int64_t per_output = 2 * model + SparseGpModel::WorkspaceBytes(max_inducing);
    const int64_t fit = PeakBytes(std::min<int64_t>(n, sparse_fit_samples), state_dim,
                                  input_dim, fit_threads);
    return state_dim * per_output +
           static_cast<int64_t>(sizeof(double)) * n * (z_dim + state_dim) + fit;
  }
  const int64_t capacity = std::max<int64_t>(16, n + n / 4 + 8);  // GpModel's room
  // Per output: Cholesky factor, cached K, inputs and scaled inputs, three vectors.
  const int64_t per_output = capacity * capacity + n * n + 2 * n * z_dim + 3 * n;
  // The model's own copy of inputs and targets.
  const int64_t shared = n * (z_dim + state_dim);
  // A refit's gradient per output being fitted: L^-1, K^-1, W = alpha alpha^T -
  // K^-1 and W o K, of which about four are alive at once, plus one for what the
  // heap keeps between them: freed matrices stay in the fitting thread's malloc
  // arena, and the outputs' new factors land beside them (measured at state_dim
  // 8, n = 1000: the peak of a real server is 244 MiB against 220 with four).
  const int64_t fitting = state_dim > 0 ? std::clamp(fit_threads, 1, state_dim) : 0;
  const int64_t doubles = state_dim * per_output + shared + fitting * 5 * n * n;
  return doubles * static_cast<int64_t>(sizeof(double));
}
int DynamicsModel::samples_since_fit() const { return state_->samples_since_fit; }
bool DynamicsModel::fitted() const { return state_->fitted; }

absl::Status DynamicsModel::CheckSamples(const Eigen::MatrixXd& states,
                                         const Eigen::MatrixXd& inputs,
                                         const Eigen::MatrixXd& next_states) const {
  const State& s = *state_;
  const Eigen::Index m = states.rows();
  if (states.cols() != s.state_dim || next_states.cols() != s.state_dim ||
      inputs.cols() != s.input_dim || inputs.rows() != m || next_states.rows() != m) {
    return absl::InvalidArgumentError(
        absl::StrCat("expected states m x ", s.state_dim, ", inputs m x ", s.input_dim,
                     ", next_states m x ", s.state_dim, "; got ", states.rows(), "x",
                     states.cols(), ", ", inputs.rows(), "x", inputs.cols(), ", ",
                     next_states.rows(), "x", next_states.cols()));
  }
  for (Eigen::Index i = 0; i < m; ++i) {
    if (!states.row(i).allFinite() || !inputs.row(i).allFinite() ||
        !next_states.row(i).allFinite()) {
      return absl::InvalidArgumentError(
          absl::StrCat("sample ", i, " contains non-finite values"));
    }
    if (s.options.target == Target::kDelta &&
        !(next_states.row(i) - states.row(i)).allFinite()) {
      return absl::InvalidArgumentError(absl::StrCat(
          "sample ", i, ": next_state - state overflows (the model's target)"));
    }
  }
  // Sums of values and of squares over all data, as the prior mean, the output
  // standardisation and the input normalisation compute them: finite iff those are.
  auto sums_finite = [](const Eigen::MatrixXd& old_rows,
                        const Eigen::MatrixXd& new_rows) {
    const Eigen::ArrayXd sum =
        old_rows.colwise().sum().array() + new_rows.colwise().sum().array();
    const Eigen::ArrayXd squares = old_rows.colwise().squaredNorm().array() +
                                   new_rows.colwise().squaredNorm().array();
    return sum.isFinite().all() && squares.isFinite().all();
  };
  const Eigen::MatrixXd targets = s.Targets(states, next_states);
  if (!sums_finite(s.targets, targets)) {
    return absl::InvalidArgumentError(
        "the targets' mean or spread over all samples would overflow: values too large");
  }
  Eigen::MatrixXd z(m, s.z_dim);
  z << states, inputs;
  if (!sums_finite(s.z, s.features.Map(z))) {
    return absl::InvalidArgumentError(
        "the inputs' spread over all samples would overflow: values too large");
  }
  return absl::OkStatus();
}

absl::Status DynamicsModel::AddSamples(const Eigen::MatrixXd& states,
                                       const Eigen::MatrixXd& inputs,
                                       const Eigen::MatrixXd& next_states) {
  const ScopedFlushDenormals flush;
  State& s = *state_;
  if (absl::Status st = CheckSamples(states, inputs, next_states); !st.ok()) return st;
  const Eigen::Index m = states.rows();
  if (m == 0) return absl::OkStatus();
  Eigen::MatrixXd z(m, s.z_dim);
  z << states, inputs;
  const Eigen::MatrixXd t = s.Targets(states, next_states);
  const int n = s.n();
  s.z.conservativeResize(n + m, Eigen::NoChange);
  s.z.bottomRows(m) = s.features.Map(z);
  s.targets.conservativeResize(n + m, Eigen::NoChange);
  s.targets.bottomRows(m) = t;
  s.samples_since_fit += static_cast<int>(m);
  // Recomputed from all targets (not updated incrementally), so a model rebuilt
  // from the same data has bit-identical prior means. A linear one stays as the
  // last Build fitted it.
  const Eigen::VectorXd old_prior_mean = s.prior_mean;
  if (!s.linear_mean()) s.prior_mean = s.targets.colwise().mean().transpose();
  if (!s.fitted) return absl::OkStatus();
  if (!s.sparse && s.options.sparse_above > 0 && s.n() > s.options.sparse_above) {
    // Crossing sparse_above between refits (or with hyperparameters that are never
    // refitted): sparse models at once, with the current hyperparameters.
    absl::Status st = Build(/*fit_hyperparameters=*/false, nullptr).status();
    if (!st.ok()) s.fitted = false;  // Refit() rebuilds from the stored data.
    return st;
  }
  // An update can fail where a factorisation from scratch does not: a sample far
  // outside the targets' spread at the last fit gets a huge standardised target,
  // and a rebuild rescales the outputs from all the data (rounding differs between
  // BLAS kernels, so which samples fail depends on the CPU). If that fails too, the
  // model is left unfitted and Refit() rebuilds it from the stored data.
  const auto recover = [this, &s](const absl::Status& failed) {
    if (Build(/*fit_hyperparameters=*/false, nullptr).ok()) return absl::OkStatus();
    s.fitted = false;
    return failed;
  };
  const Eigen::MatrixXd zn = s.Normalise(z);
  // The new samples' targets on the prior mean as it was (a linear one stays).
  const Eigen::MatrixXd old_mean =
      (zn * s.prior_slopes.transpose()).rowwise() + old_prior_mean.transpose();
  if (s.sparse) {
    // Added on the old prior mean, then every target shifted to the new one.
    for (int j = 0; j < s.state_dim; ++j) {
      absl::Status st;
      for (Eigen::Index i = 0; i < m && st.ok(); ++i) {
        st = s.sparse_gps[j].AddSample(zn.row(i).transpose(),
                                       (t(i, j) - old_mean(i, j)) / s.out_std(j));
      }
      if (!st.ok()) return recover(st);
      if (!s.linear_mean()) {
        s.sparse_gps[j].ShiftTargets((s.prior_mean(j) - old_prior_mean(j)) /
                                     s.out_std(j));
      }
    }
    return absl::OkStatus();
  }
  // O(n^2) row appends with the current normalisation and hyperparameters, then
  // (constant mean) every target re-centred on the new prior mean (two O(n^2)
  // solves).
  for (int j = 0; j < s.state_dim; ++j) {
    absl::Status st;
    for (Eigen::Index i = 0; i < m && st.ok(); ++i) {
      const double mean = s.linear_mean() ? old_mean(i, j) : s.prior_mean(j);
      st = s.gps[j].AddSample(zn.row(i).transpose(), (t(i, j) - mean) / s.out_std(j));
    }
    if (st.ok() && !s.linear_mean()) {
      st = s.gps[j].SetTargets(s.StandardisedTargets(j, s.out_std(j)));
    }
    if (!st.ok()) return recover(st);
  }
  return absl::OkStatus();
}

absl::StatusOr<FitSummary> DynamicsModel::Refit(const FitStopFn& stop) {
  return Build(/*fit=*/true, stop);
}

absl::Status DynamicsModel::Rebuild() {
  if (static_cast<int>(state_->data_hyperparameters.size()) != state_->state_dim) {
    return absl::FailedPreconditionError("Rebuild: no hyperparameters to rebuild with");
  }
  return Build(/*fit=*/false, nullptr).status();
}

absl::StatusOr<FitSummary> DynamicsModel::Build(bool fit_hyperparameters,
                                                const FitStopFn& stop) {
  const ScopedFlushDenormals flush;
  const auto t0 = std::chrono::steady_clock::now();
  State& s = *state_;
  const int n = s.n();
  if (n < 2) {
    return absl::FailedPreconditionError(
        absl::StrCat("Refit needs at least 2 samples, have ", n));
  }
  const bool fit = fit_hyperparameters && s.options.fit_kernel;
  if (!s.normalisation_resolved) {
    const Eigen::RowVectorXd mean = s.z.colwise().mean();
    const Eigen::RowVectorXd std =
        ((s.z.rowwise() - mean).colwise().squaredNorm() / n).cwiseSqrt();
    for (Eigen::Index i = 0; i < s.z.cols(); ++i) {
      if (!std::isfinite(s.options.input_center(i))) s.options.input_center(i) = mean(i);
      if (!std::isfinite(s.options.input_half_width(i))) {
        s.options.input_half_width(i) =
            std::max(std::sqrt(3.0) * std(i), kMinDataHalfWidth);
      }
    }
    s.center = s.options.input_center;
    s.half_width = s.options.input_half_width;
    s.normalisation_resolved = true;
  }
  const Eigen::MatrixXd zn = s.NormaliseFeatures(s.z);
  // A linear prior mean is fitted on the samples of this fit (of the last one for
  // a rebuild), so that a restored model rebuilds it from the same samples.
  // (A count not known, as after an import of an old archive: all samples.)
  int mean_samples = fit_hyperparameters ? n : n - s.samples_since_fit;
  if (mean_samples < 2) mean_samples = n;
  const PriorFit prior = s.linear_mean() ? FitLinearPriorMean(zn, s.targets, mean_samples)
                                         : PriorFit{s.prior_mean, s.prior_slopes};
  const Eigen::MatrixXd residuals = s.Residuals(zn, prior);
  // Output scale of the fit, floored at the measurement noise std so that a
  // (nearly) constant output does not blow up.
  const Eigen::VectorXd out_std =
      (residuals.colwise().squaredNorm() / n)
          .cwiseSqrt()
          .transpose()
          .cwiseMax(std::sqrt(s.options.measurement_noise_variance));
  // Long sessions: hyperparameters from a strided subset, then sparse models on
  // all the data.
  const bool sparse = s.options.sparse_above > 0 && n > s.options.sparse_above;
  std::vector<Eigen::Index> subset;
  if (sparse) {
    const int count =
        static_cast<int>(std::min<int64_t>(n, s.options.sparse_fit_samples));
    for (int i = 0; i < count; ++i) {
      subset.push_back(static_cast<Eigen::Index>(int64_t{i} * n / count));
    }
  }
  const Eigen::MatrixXd zn_fit = sparse ? Eigen::MatrixXd(zn(subset, Eigen::all)) : zn;

  const int outputs = s.state_dim;
  const bool have_warm = !s.data_hyperparameters.empty();
  const bool default_start =
      !have_warm || n >= s.options.fit.default_start_growth * s.default_start_n;
  std::vector<GpModel> gps(outputs);
  std::vector<SparseGpModel> sparse_gps(sparse ? outputs : 0,
                                        SparseGpModel(s.options.sparse));
  std::vector<double> sparse_fit_lml(sparse ? outputs : 0);
  std::vector<absl::StatusOr<FitSummary>> results(outputs, FitSummary{});
  auto fit_output = [&](int j) {
    const ScopedFlushDenormals thread_flush;  // the fit's worker threads too
    const double var = out_std(j) * out_std(j);
    Eigen::VectorXd y_all = residuals.col(j) / out_std(j);
    Eigen::VectorXd y = sparse ? Eigen::VectorXd(y_all(subset)) : y_all;
    if (!fit) {
      const Hyperparameters h = ToNormalised(
          s.options.fit_kernel ? s.data_hyperparameters[j] : s.options.fixed[j],
          s.half_width, out_std(j));
      // Sparse: the subset's exact GP only for its log marginal likelihood.
      absl::Status st = gps[j].Reset(sparse ? zn_fit : zn, std::move(y), h);
      if (st.ok() && sparse) {
        sparse_fit_lml[j] = gps[j].log_marginal_likelihood();
        st = sparse_gps[j].Reset(zn, std::move(y_all), h);
      }
      results[j] = st.ok() ? absl::StatusOr<FitSummary>(FitSummary{}) : st;
      return;
    }
    const double noise =
        (s.options.fit_noise ? s.options.measurement_noise_variance : s.FixedNoise()) /
        var;
    std::optional<Hyperparameters> warm;
    Hyperparameters initial;
    if (j < static_cast<int>(s.data_hyperparameters.size())) {
      warm = ToNormalised(s.data_hyperparameters[j], s.half_width, out_std(j));
      if (!s.options.fit_noise) warm->noise_variance = noise;
      initial = *warm;
    } else {
      initial.signal_variance = 1.0;
      initial.lengthscales = Eigen::VectorXd::Ones(s.z.cols());
      initial.noise_variance = std::max(noise, 1e-2);
      if (!s.options.fit_noise) initial.noise_variance = noise;
    }
    if (absl::Status st = gps[j].Reset(zn_fit, std::move(y), initial); !st.ok()) {
      results[j] = st;
      return;
    }
    FitOptions fit_options = s.options.fit;
    fit_options.warm_default_start = fit_options.warm_default_start && default_start;
    fit_options.seed = SplitMix64(
        s.options.fit.seed ^ SplitMix64(static_cast<uint64_t>(s.refits) * 1024u + j));
    results[j] =
        FitHyperparameters(fit_options, noise, s.options.fit_noise, warm, &gps[j], stop);
    if (!sparse || !results[j].ok()) return;
    sparse_fit_lml[j] = gps[j].log_marginal_likelihood();
    if (absl::Status st =
            sparse_gps[j].Reset(zn, std::move(y_all), gps[j].hyperparameters());
        !st.ok()) {
      results[j] = st;
    }
  };
  const int threads = (outputs >= 2 && n >= kMinSamplesForThreads)
                          ? std::min(s.options.fit_threads, outputs)
                          : 1;
  std::atomic<int> next_output{0};
  const auto fit_the_rest = [&] {
    for (int j = next_output++; j < outputs; j = next_output++) fit_output(j);
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t) {
    pool.emplace_back([&, t] {
      if (t >= 2 && s.options.run_if_worker_free) {
        s.options.run_if_worker_free(fit_the_rest);
      } else {
        fit_the_rest();
      }
    });
  }
  fit_the_rest();
  for (std::thread& th : pool) th.join();

  FitSummary summary;
  summary.fitted = fit;
  for (const absl::StatusOr<FitSummary>& r : results) {
    if (!r.ok()) return r.status();  // the previous model stays in place
    summary.starts += r->starts;
    summary.iterations += r->iterations;
    summary.failed_starts += r->failed_starts;
    summary.evaluations += r->evaluations;
    summary.stopped = summary.stopped || r->stopped;
  }
  s.sparse = sparse;
  s.out_std = out_std;
  s.prior_mean = prior.intercept;
  s.prior_slopes = prior.slopes;
  s.data_hyperparameters.clear();
  for (int j = 0; j < outputs; ++j) {
    const Hyperparameters& h =
        sparse ? sparse_gps[j].hyperparameters() : gps[j].hyperparameters();
    s.data_hyperparameters.push_back(ToData(h, s.half_width, out_std(j)));
    if (sparse) {
      sparse_fit_lml[j] -= static_cast<double>(subset.size()) * std::log(out_std(j));
    }
  }
  // The subset's exact GPs are not kept: the sparse models replace them.
  s.gps = sparse ? std::vector<GpModel>() : std::move(gps);
  s.sparse_gps = std::move(sparse_gps);
  s.sparse_fit_lml = std::move(sparse_fit_lml);
  s.fitted = true;
  // A stopped fit keeps samples_since_fit so that the next Refit() is still due
  // and continues from the best point seen.
  // A rebuild is no fit: samples_since_fit and the fit's counters stay.
  if (!fit_hyperparameters) return summary;
  if (!summary.stopped) {
    s.samples_since_fit = 0;
    if (s.options.fit_kernel &&
        (!have_warm || (default_start && s.options.fit.warm_default_start))) {
      s.default_start_n = n;
    }
  }
  ++s.refits;
  summary.wall_time_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
          .count();
  return summary;
}

absl::Status DynamicsModel::SeedWarmStart(std::vector<Hyperparameters> data_units,
                                          int fitted_samples) {
  State& s = *state_;
  if (s.fitted) {
    return absl::FailedPreconditionError("SeedWarmStart: the model is already fitted");
  }
  if (static_cast<int>(data_units.size()) != s.state_dim) {
    return absl::InvalidArgumentError(absl::StrCat("SeedWarmStart: need ", s.state_dim,
                                                   " hyperparameter sets, got ",
                                                   data_units.size()));
  }
  for (const Hyperparameters& h : data_units) {
    if (h.lengthscales.size() != s.z.cols() || !PositiveFinite(h.signal_variance) ||
        !PositiveFinite(h.noise_variance) ||
        !(h.lengthscales.array().isFinite() && h.lengthscales.array() > 0.0).all()) {
      return absl::InvalidArgumentError(
          "SeedWarmStart: need kernel_inputs positive finite lengthscales and positive "
          "finite "
          "variances");
    }
  }
  s.data_hyperparameters = std::move(data_units);
  s.default_start_n = s.n();
  s.samples_since_fit = s.n() - std::clamp(fitted_samples, 0, s.n());
  return absl::OkStatus();
}

void DynamicsModel::Predict(const Eigen::MatrixXd& z, Eigen::MatrixXd* mean,
                            Eigen::MatrixXd* variance,
                            std::vector<Eigen::MatrixXd>* mean_jacobians,
                            std::vector<Eigen::MatrixXd>* variance_jacobians) const {
  const ScopedFlushDenormals flush;
  const State& s = *state_;
  const Eigen::Index m = z.rows();
  const int sd = s.state_dim;
  const int zd = s.z_dim;
  if (mean != nullptr) mean->resize(m, sd);
  if (variance != nullptr) variance->resize(m, sd);
  if (mean_jacobians != nullptr) mean_jacobians->assign(m, Eigen::MatrixXd(sd, zd));
  if (variance_jacobians != nullptr)
    variance_jacobians->assign(m, Eigen::MatrixXd(sd, zd));
  if (!s.fitted || z.cols() != zd) {  // precondition violated: NaN everywhere
    const double nan = std::numeric_limits<double>::quiet_NaN();
    if (mean != nullptr) mean->setConstant(nan);
    if (variance != nullptr) variance->setConstant(nan);
    if (mean_jacobians != nullptr) {
      for (Eigen::MatrixXd& j : *mean_jacobians) j.setConstant(nan);
    }
    if (variance_jacobians != nullptr) {
      for (Eigen::MatrixXd& j : *variance_jacobians) j.setConstant(nan);
    }
    return;
  }
  const Eigen::MatrixXd zn = s.Normalise(z);
  const Eigen::RowVectorXd inv_h = s.half_width.cwiseInverse().transpose();
  const bool delta = s.options.target == Target::kDelta;
  // The Jacobians are filled w.r.t. the features (sd x kernel_inputs per point)
  // and, with angles, pulled back to z after the loop; without, features are z.
  const Eigen::Index features = s.z.cols();
  if (mean_jacobians != nullptr && features != zd) {
    mean_jacobians->assign(m, Eigen::MatrixXd(sd, features));
  }
  if (variance_jacobians != nullptr && features != zd) {
    variance_jacobians->assign(m, Eigen::MatrixXd(sd, features));
  }
  Eigen::VectorXd mu, var;
  Eigen::MatrixXd dmu, dvar;
  for (int j = 0; j < sd; ++j) {
    const double sj = s.out_std(j);
    Eigen::VectorXd* mu_out = mean != nullptr ? &mu : nullptr;
    Eigen::VectorXd* var_out = variance != nullptr ? &var : nullptr;
    Eigen::MatrixXd* dmu_out = mean_jacobians != nullptr ? &dmu : nullptr;
    Eigen::MatrixXd* dvar_out = variance_jacobians != nullptr ? &dvar : nullptr;
    if (s.sparse) {
      s.sparse_gps[j].Predict(zn, mu_out, var_out, dmu_out, dvar_out);
    } else {
      s.gps[j].Predict(zn, mu_out, var_out, dmu_out, dvar_out);
    }
    if (mean != nullptr) {
      mean->col(j) = (s.prior_mean(j) + sj * mu.array()).matrix();
      if (s.linear_mean()) mean->col(j) += zn * s.prior_slopes.row(j).transpose();
      if (delta) mean->col(j) += z.col(j);
    }
    if (variance != nullptr) variance->col(j) = sj * sj * var;
    for (Eigen::Index i = 0; i < m; ++i) {
      if (mean_jacobians != nullptr) {
        (*mean_jacobians)[i].row(j) =
            (sj * dmu.row(i) + s.prior_slopes.row(j)).cwiseProduct(inv_h);
      }
      if (variance_jacobians != nullptr) {
        (*variance_jacobians)[i].row(j) = (sj * sj * dvar.row(i)).cwiseProduct(inv_h);
      }
    }
  }
  for (Eigen::Index i = 0; i < m; ++i) {
    // d / dz = (d / d features) (d features / dz).
    if (mean_jacobians != nullptr) {
      if (features != zd) {
        (*mean_jacobians)[i] = s.features.PullBack((*mean_jacobians)[i], z.row(i));
      }
      if (delta) (*mean_jacobians)[i].diagonal().head(sd).array() += 1.0;
    }
    if (variance_jacobians != nullptr && features != zd) {
      (*variance_jacobians)[i] = s.features.PullBack((*variance_jacobians)[i], z.row(i));
    }
  }
}

namespace {

// A point set in the model's normalised inputs with L \ K(X, z) of every output.
struct GpPreparedPoints final : DynamicsPredictor::PreparedPoints {
  Eigen::MatrixXd z;                     // m x z_dim, as given
  Eigen::MatrixXd normalised;            // m x kernel_inputs
  std::vector<Eigen::MatrixXd> factors;  // per output: n x m
};

const GpPreparedPoints& AsGp(const DynamicsPredictor::PreparedPoints& p) {
  return static_cast<const GpPreparedPoints&>(p);
}

}  // namespace

std::unique_ptr<DynamicsPredictor::PreparedPoints> DynamicsModel::PreparePoints(
    const Eigen::MatrixXd& z) const {
  const State& s = *state_;
  if (!s.fitted || s.sparse || z.cols() != s.z_dim) return nullptr;
  auto prepared = std::make_unique<GpPreparedPoints>();
  prepared->z = z;
  prepared->normalised = s.Normalise(z);
  for (const GpModel& gp : s.gps) {
    prepared->factors.push_back(gp.CrossFactor(prepared->normalised));
  }
  return prepared;
}

std::vector<Eigen::MatrixXd> DynamicsModel::PosteriorCovariance(
    const PreparedPoints& a, const PreparedPoints& b) const {
  const State& s = *state_;
  const GpPreparedPoints& pa = AsGp(a);
  const GpPreparedPoints& pb = AsGp(b);
  std::vector<Eigen::MatrixXd> cov;
  for (int j = 0; j < s.state_dim; ++j) {
    cov.push_back(s.out_std(j) * s.out_std(j) *
                  s.gps[j].PosteriorCovariance(pa.normalised, pa.factors[j],
                                               pb.normalised, pb.factors[j]));
  }
  return cov;
}

Eigen::MatrixXd DynamicsModel::PosteriorVariance(const PreparedPoints& a) const {
  const State& s = *state_;
  const GpPreparedPoints& pa = AsGp(a);
  Eigen::MatrixXd variance(pa.normalised.rows(), s.state_dim);
  for (int j = 0; j < s.state_dim; ++j) {
    // k(z, z) = signal variance for the SE kernel; clamped at 0 as Predict does.
    variance.col(j) = s.out_std(j) * s.out_std(j) *
                      (s.gps[j].hyperparameters().signal_variance -
                       pa.factors[j].colwise().squaredNorm().transpose().array())
                          .cwiseMax(0.0)
                          .matrix();
  }
  return variance;
}

Eigen::MatrixXd DynamicsModel::PosteriorCovarianceGradient(
    const PreparedPoints& a, const std::vector<CovarianceTerm>& terms) const {
  const State& s = *state_;
  const GpPreparedPoints& pa = AsGp(a);
  Eigen::MatrixXd grad = Eigen::MatrixXd::Zero(pa.normalised.rows(), s.z.cols());
  for (int j = 0; j < s.state_dim; ++j) {
    std::vector<GpModel::CovarianceTerm> gp_terms;
    for (const CovarianceTerm& t : terms) {
      const GpPreparedPoints& pb = AsGp(*t.b);
      gp_terms.push_back({&pb.normalised, &pb.factors[j], &(*t.weights)[j]});
    }
    grad += s.out_std(j) * s.out_std(j) *
            s.gps[j].PosteriorCovarianceGradient(pa.normalised, gp_terms);
  }
  // Normalised features: d / df = (d / df_n) / half_width; then d / dz.
  grad = grad * s.half_width.cwiseInverse().asDiagonal();
  if (s.features.angles().empty()) return grad;
  Eigen::MatrixXd out(grad.rows(), s.z_dim);
  for (Eigen::Index i = 0; i < grad.rows(); ++i) {
    out.row(i) = s.features.PullBack(grad.row(i), pa.z.row(i));
  }
  return out;
}

Eigen::VectorXd DynamicsModel::prior_means() const { return state_->prior_mean; }

Eigen::MatrixXd DynamicsModel::prior_mean_slopes() const {
  const State& s = *state_;
  if (!s.linear_mean() || !s.fitted) return Eigen::MatrixXd();
  return s.prior_slopes * s.half_width.cwiseInverse().asDiagonal();
}

std::optional<model::ModelData> DynamicsModel::ExportModel() const {
  const State& s = *state_;
  if (!s.fitted) return std::nullopt;
  model::ModelData data;
  data.state_dim = s.state_dim;
  data.input_dim = s.input_dim;
  data.delta = s.options.target == Target::kDelta;
  data.angle_dims = s.features.angles();
  data.feature_center = s.center;
  data.feature_half_width = s.half_width;
  data.prior_mean = s.prior_mean;
  data.prior_slopes = s.prior_slopes;
  data.output_std = s.out_std;
  data.noise_variance = noise_variances();
  data.sample_count = s.n();
  for (int j = 0; j < s.state_dim; ++j) {
    model::OutputData o;
    if (s.sparse) {
      const SparseGpModel& gp = s.sparse_gps[static_cast<size_t>(j)];
      o.signal_variance = gp.hyperparameters().signal_variance;
      o.lengthscales = gp.hyperparameters().lengthscales;
      o.points = gp.inputs()(gp.inducing_indices(), Eigen::all);
      o.weights = gp.weights();
      o.factor = gp.kernel_factor();
      o.sparse_factor = gp.b_factor();
    } else {
      const GpModel& gp = s.gps[static_cast<size_t>(j)];
      o.signal_variance = gp.hyperparameters().signal_variance;
      o.lengthscales = gp.hyperparameters().lengthscales;
      o.points = gp.inputs();
      o.weights = gp.alpha();
      o.factor = gp.cholesky();
    }
    data.outputs.push_back(std::move(o));
  }
  return data;
}

Eigen::VectorXd DynamicsModel::noise_variances() const {
  const State& s = *state_;
  Eigen::VectorXd out(s.state_dim);
  for (int j = 0; j < s.state_dim; ++j) {
    if (j < static_cast<int>(s.data_hyperparameters.size())) {
      out(j) = s.data_hyperparameters[j].noise_variance;
    } else if (!s.options.fit_kernel) {
      out(j) = s.options.fixed[j].noise_variance;
    } else {
      out(j) = s.FixedNoise();
    }
  }
  return out;
}

std::vector<Hyperparameters> DynamicsModel::hyperparameters() const {
  return state_->data_hyperparameters;
}

std::vector<double> DynamicsModel::log_marginal_likelihoods() const {
  const State& s = *state_;
  std::vector<double> out;
  if (!s.fitted) return out;
  if (s.sparse) return s.sparse_fit_lml;
  for (int j = 0; j < s.state_dim; ++j) {
    out.push_back(s.gps[j].log_marginal_likelihood() -
                  s.gps[j].size() * std::log(s.out_std(j)));
  }
  return out;
}

std::vector<BoundHits> DynamicsModel::bound_hits() const {
  const State& s = *state_;
  std::vector<BoundHits> hits;
  if (!s.fitted || !s.options.fit_kernel) return hits;
  for (int j = 0; j < s.state_dim; ++j) {
    hits.push_back(
        HitBounds(ToNormalised(s.data_hyperparameters[j], s.half_width, s.out_std(j)),
                  s.options.fit));
  }
  return hits;
}

bool DynamicsModel::sparse() const { return state_->sparse; }

std::vector<int> DynamicsModel::inducing_counts() const {
  std::vector<int> counts;
  for (const SparseGpModel& gp : state_->sparse_gps)
    counts.push_back(gp.inducing_count());
  return counts;
}

}  // namespace excite::gp
