#include "server/service/session_options.h"

#include <limits>

#include "server/service/strategy_names.h"

namespace excite::service {
namespace {

// Beyond Ipopt's infinity (1e19): a bound that is none.
constexpr double kNoBound = 1e20;

}  // namespace

gp::Hyperparameters FromProto(const v1::Hyperparameters& proto) {
  gp::Hyperparameters h;
  h.signal_variance = proto.signal_variance();
  h.lengthscales.resize(proto.lengthscales_size());
  for (int i = 0; i < proto.lengthscales_size(); ++i)
    h.lengthscales(i) = proto.lengthscales(i);
  h.noise_variance = proto.noise_variance();
  return h;
}

v1::Hyperparameters ToProto(const gp::Hyperparameters& hyperparameters) {
  v1::Hyperparameters proto;
  proto.set_signal_variance(hyperparameters.signal_variance);
  for (Eigen::Index i = 0; i < hyperparameters.lengthscales.size(); ++i) {
    proto.add_lengthscales(hyperparameters.lengthscales(i));
  }
  proto.set_noise_variance(hyperparameters.noise_variance);
  return proto;
}

gp::DynamicsModelOptions ModelOptionsFromConfig(const v1::SessionConfig& config) {
  gp::DynamicsModelOptions options;
  options.state_dim = config.state_dim();
  options.input_dim = config.input_dim();
  options.target =
      config.target() == v1::TARGET_NEXT ? gp::Target::kNext : gp::Target::kDelta;
  options.angle_dims.assign(config.angle_dims().begin(), config.angle_dims().end());
  options.prior_mean = config.prior_mean() == v1::PRIOR_MEAN_LINEAR
                           ? gp::PriorMean::kLinear
                           : gp::PriorMean::kConstant;
  options.measurement_noise_variance = config.noise().variance();
  options.fit_noise = config.noise().fit();
  options.fit_kernel = config.kernel().fit();
  for (const v1::Hyperparameters& h : config.kernel().fixed()) {
    options.fixed.push_back(FromProto(h));
  }
  options.fit.min_lengthscale = config.kernel().lengthscale_bounds().lower();
  options.fit.max_lengthscale = config.kernel().lengthscale_bounds().upper();
  options.fit.min_signal_variance = config.kernel().signal_variance_bounds().lower();
  options.fit.max_signal_variance = config.kernel().signal_variance_bounds().upper();
  options.fit.restarts = config.kernel().restarts();
  options.fit.max_iterations = config.kernel().max_iterations();
  options.fit.seed = config.seed();
  // Unset in configs stored before sparse models existed: those sessions stay exact.
  options.sparse_above = config.sparse().above_samples();
  if (config.sparse().max_inducing() > 0) {
    options.sparse.max_inducing = config.sparse().max_inducing();
  }
  if (config.sparse().fit_samples() > 0) {
    options.sparse_fit_samples = config.sparse().fit_samples();
  }
  if (config.sparse().inducing_tolerance() > 0.0) {
    options.sparse.inducing_tolerance = config.sparse().inducing_tolerance();
  }

  const int dx = config.state_dim();
  const int z_dim = dx + config.input_dim();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  options.input_center = Eigen::VectorXd::Constant(z_dim, nan);
  options.input_half_width = Eigen::VectorXd::Constant(z_dim, nan);
  for (int i = 0; i < config.state_bounds_size(); ++i) {
    const v1::Interval& b = config.state_bounds(i);
    options.input_center(i) = 0.5 * (b.lower() + b.upper());
    options.input_half_width(i) = 0.5 * (b.upper() - b.lower());
  }
  for (int i = 0; i < config.input_bounds_size(); ++i) {
    const v1::Interval& b = config.input_bounds(i);
    options.input_center(dx + i) = 0.5 * (b.lower() + b.upper());
    options.input_half_width(dx + i) = 0.5 * (b.upper() - b.lower());
  }
  return options;
}

plan::PlanOptions PlanOptionsFromConfig(const v1::SessionConfig& config) {
  plan::PlanOptions options;
  options.strategy = EngineStrategy(config.strategy()).strategy;
  options.horizon = config.horizon();
  options.input_lower.resize(config.input_dim());
  options.input_upper.resize(config.input_dim());
  for (int i = 0; i < config.input_bounds_size(); ++i) {
    options.input_lower(i) = config.input_bounds(i).lower();
    options.input_upper(i) = config.input_bounds(i).upper();
  }
  if (config.state_bounds_size() == config.state_dim()) {
    options.state_lower.resize(config.state_dim());
    options.state_upper.resize(config.state_dim());
    for (int i = 0; i < config.state_bounds_size(); ++i) {
      options.state_lower(i) = config.state_bounds(i).lower();
      options.state_upper(i) = config.state_bounds(i).upper();
    }
  }
  options.max_iterations = config.planner().max_iterations();
  options.restarts = config.planner().restarts();
  options.tolerance = config.planner().tolerance();
  options.seed = config.seed();
  // Unset (0) parameters of a strategy that does not use them keep the engine's
  // defaults; validation filled in those of the session's strategy.
  const v1::SignalConfig& signal = config.signal();
  if (signal.prbs_min_hold() != 0) options.signal.prbs_min_hold = signal.prbs_min_hold();
  if (signal.chirp_start_frequency() != 0.0) {
    options.signal.chirp_start_frequency = signal.chirp_start_frequency();
  }
  if (signal.chirp_end_frequency() != 0.0) {
    options.signal.chirp_end_frequency = signal.chirp_end_frequency();
  }
  if (signal.chirp_period() != 0) options.signal.chirp_period = signal.chirp_period();
  if (signal.random_hold() != 0) options.signal.random_hold = signal.random_hold();
  const v1::SepConfig& sep = config.sep();
  if (sep.search_starts() != 0) options.sep.search_starts = sep.search_starts();
  if (sep.search_samples() != 0) options.sep.search_samples = sep.search_samples();
  if (sep.search_iterations() != 0) {
    options.sep.search_iterations = sep.search_iterations();
  }
  options.angle_dims.assign(config.angle_dims().begin(), config.angle_dims().end());
  const v1::SafetyConfig& safety = config.safety();
  if (safety.state_bounds_size() == config.state_dim()) {
    options.safe_box.lower.resize(config.state_dim());
    options.safe_box.upper.resize(config.state_dim());
    for (int i = 0; i < safety.state_bounds_size(); ++i) {
      options.safe_box.lower(i) = safety.state_bounds(i).lower();
      options.safe_box.upper(i) = safety.state_bounds(i).upper();
    }
    // An angle wraps, so no box holds it (validation saw a full turn): Ipopt
    // takes bounds beyond 1e19 as none.
    for (int a : options.angle_dims) {
      options.safe_box.lower(a) = -kNoBound;
      options.safe_box.upper(a) = kNoBound;
    }
    if (safety.has_margin()) options.safe_box.margin = safety.margin();
  }
  if (config.roi().reference_points() != 0) {
    options.roi_reference_points = config.roi().reference_points();
  }
  if (config.optimistic().has_beta()) options.optimism_beta = config.optimistic().beta();
  for (int member : config.auto_().members()) {
    options.auto_members.push_back(
        EngineStrategy(static_cast<v1::Strategy>(member)).strategy);
  }
  options.auto_chooser = EngineChooser(config.auto_().chooser());
  return options;
}

session::SessionSpec SessionSpecFromConfig(const v1::SessionConfig& config) {
  session::SessionSpec spec;
  spec.state_dim = config.state_dim();
  spec.input_dim = config.input_dim();
  spec.model = ModelOptionsFromConfig(config);
  spec.plan = PlanOptionsFromConfig(config);
  spec.refit.fit_kernel = config.kernel().fit();
  spec.refit.never = config.refit().never();
  spec.refit.schedule = {config.refit().every_samples(), config.refit().growth()};
  spec.refit.min_samples = config.refit().min_samples();
  spec.time_budget_s = config.planner().time_budget_s();
  spec.config = config.SerializeAsString();
  return spec;
}

}  // namespace excite::service
