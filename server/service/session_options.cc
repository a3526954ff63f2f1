#include "server/service/session_options.h"

#include <limits>

namespace excite::service {

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
  switch (config.strategy()) {
    case v1::STRATEGY_PA:
      options.strategy = plan::Strategy::kPa;
      break;
    case v1::STRATEGY_GREEDY:
      options.strategy = plan::Strategy::kGreedy;
      break;
    default:
      options.strategy = plan::Strategy::kRec;
      break;
  }
  options.horizon = config.horizon();
  options.input_lower.resize(config.input_dim());
  options.input_upper.resize(config.input_dim());
  for (int i = 0; i < config.input_bounds_size(); ++i) {
    options.input_lower(i) = config.input_bounds(i).lower();
    options.input_upper(i) = config.input_bounds(i).upper();
  }
  options.max_iterations = config.planner().max_iterations();
  options.restarts = config.planner().restarts();
  options.tolerance = config.planner().tolerance();
  options.seed = config.seed();
  return options;
}

}  // namespace excite::service
