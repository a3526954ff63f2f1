#include "server/service/config_validation.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "common/angles.h"
#include "server/gp/dynamics_model.h"
#include "server/gp/hyperparameter_fit.h"
#include "server/gp/sparse_gp_model.h"
#include "server/plan/planner.h"
#include "server/service/config_rules.h"
#include "server/service/field_violation.h"
#include "server/service/strategy_names.h"
#include "server/service/value_ranges.h"

namespace excite::service {
namespace {

std::string Field(absl::string_view path, absl::string_view name) {
  return absl::StrCat(path, ".", name);
}

std::string Indexed(absl::string_view path, absl::string_view name, int index) {
  return absl::StrCat(path, ".", name, "[", index, "]");
}

absl::Status Invalid(absl::string_view field, absl::string_view what) {
  return FieldViolationError(field, what);
}

// "STRATEGY_REC, STRATEGY_PA, ...": the strategies a config may name.
std::string ValidStrategyNames() {
  std::vector<std::string> names;
  const google::protobuf::EnumDescriptor* strategies = v1::Strategy_descriptor();
  for (int i = 0; i < strategies->value_count(); ++i) {
    if (strategies->value(i)->number() != v1::STRATEGY_UNSPECIFIED) {
      names.push_back(strategies->value(i)->name());
    }
  }
  return absl::StrJoin(names, ", ");
}

absl::Status CheckInterval(absl::string_view field, const v1::Interval& interval) {
  if (!std::isfinite(interval.lower()) || !std::isfinite(interval.upper())) {
    return Invalid(field, absl::StrCat("lower (", interval.lower(), ") and upper (",
                                       interval.upper(), ") must be finite"));
  }
  if (!(interval.lower() < interval.upper())) {
    return Invalid(field, absl::StrCat("lower (", interval.lower(), ") must be < upper (",
                                       interval.upper(), ")"));
  }
  return absl::OkStatus();
}

// An interval of states or inputs (value_ranges.h: its half-width normalises the
// model's inputs).
absl::Status CheckDataInterval(absl::string_view field, const v1::Interval& interval) {
  if (absl::Status s = CheckInterval(field, interval); !s.ok()) return s;
  if (std::abs(interval.lower()) > kMaxAbsValue ||
      std::abs(interval.upper()) > kMaxAbsValue) {
    return Invalid(field,
                   absl::StrCat("lower (", interval.lower(), ") and upper (",
                                interval.upper(), ") must be within +-", kMaxAbsValue));
  }
  if (!(interval.upper() - interval.lower() >= kMinIntervalWidth)) {
    return Invalid(field, absl::StrCat("upper - lower must be >= ", kMinIntervalWidth,
                                       ", got ", interval.upper() - interval.lower()));
  }
  return absl::OkStatus();
}

// Positive bounds of a fit on standardised data, within [min, max] (they are
// bounds of log-parameters).
absl::Status CheckFitBounds(absl::string_view field, v1::Interval* interval, bool present,
                            double def_lower, double def_upper, double min, double max) {
  if (!present) {
    interval->set_lower(def_lower);
    interval->set_upper(def_upper);
    return absl::OkStatus();
  }
  if (absl::Status s = CheckInterval(field, *interval); !s.ok()) return s;
  if (!(interval->lower() >= min) || !(interval->upper() <= max)) {
    return Invalid(field, absl::StrCat("must lie within [", min, ", ", max, "], got [",
                                       interval->lower(), ", ", interval->upper(), "]"));
  }
  return absl::OkStatus();
}

// A finite number in [min, max] (min > 0).
absl::Status CheckPositive(absl::string_view field, double value, double min,
                           double max) {
  if (!std::isfinite(value) || !(value >= min) || !(value <= max)) {
    return Invalid(field, absl::StrCat("must be in [", min, ", ", max, "], got ", value));
  }
  return absl::OkStatus();
}

absl::Status ValidateKernel(absl::string_view path, const v1::SessionConfig& config,
                            v1::KernelConfig* kernel) {
  const std::string kpath = Field(path, "kernel");
  const int kernel_inputs = KernelInputs(config);
  if (!kernel->fit()) {
    if (kernel->fixed_size() != config.state_dim()) {
      return Invalid(
          Field(kpath, "fixed"),
          absl::StrCat("must have state_dim (", config.state_dim(),
                       ") entries when kernel.fit is false, got ", kernel->fixed_size()));
    }
    for (int i = 0; i < kernel->fixed_size(); ++i) {
      if (absl::Status s = ValidateHyperparameters(Indexed(kpath, "fixed", i),
                                                   kernel->fixed(i), kernel_inputs);
          !s.ok()) {
        return s;
      }
    }
  } else if (kernel->fixed_size() != 0) {
    return Invalid(Field(kpath, "fixed"),
                   absl::StrCat("must be empty when kernel.fit is true (fixed "
                                "hyperparameters are used only without a fit), got ",
                                kernel->fixed_size(), " entries"));
  }
  const gp::FitOptions fit_defaults;
  // Read before mutable_*() creates the field: argument evaluation order is
  // unspecified (clang evaluates left to right, and rejected every fitted config
  // without bounds as "lower (0) must be < upper (0)").
  const bool has_lengthscale_bounds = kernel->has_lengthscale_bounds();
  const bool has_signal_variance_bounds = kernel->has_signal_variance_bounds();
  if (absl::Status s = CheckFitBounds(
          Field(kpath, "lengthscale_bounds"), kernel->mutable_lengthscale_bounds(),
          has_lengthscale_bounds, fit_defaults.min_lengthscale,
          fit_defaults.max_lengthscale, kMinFitLengthscale, kMaxFitLengthscale);
      !s.ok()) {
    return s;
  }
  if (absl::Status s = CheckFitBounds(
          Field(kpath, "signal_variance_bounds"),
          kernel->mutable_signal_variance_bounds(), has_signal_variance_bounds,
          fit_defaults.min_signal_variance, fit_defaults.max_signal_variance,
          kMinFitSignalVariance, kMaxFitSignalVariance);
      !s.ok()) {
    return s;
  }
  return absl::OkStatus();  // restarts, max_iterations: config_rules.cc
}

// AutoConfig: a known chooser (UNSPECIFIED -> PORTFOLIO); members each once, each
// one that can be a member; the chooser's default (plan::DefaultAutoMembers)
// filled in for STRATEGY_AUTO when none is named.
absl::Status ValidateAuto(absl::string_view path, v1::SessionConfig* config) {
  if (config->strategy() != v1::STRATEGY_AUTO) return absl::OkStatus();
  v1::AutoConfig* auto_config = config->mutable_auto_();
  if (auto_config->chooser() == v1::AutoConfig::CHOOSER_UNSPECIFIED) {
    auto_config->set_chooser(v1::AutoConfig::CHOOSER_PORTFOLIO);
  }
  if (!v1::AutoConfig::Chooser_IsValid(auto_config->chooser())) {
    return Invalid(
        Field(Field(path, "auto"), "chooser"),
        absl::StrCat("unknown value ", static_cast<int>(auto_config->chooser()),
                     "; valid: CHOOSER_BANDIT, CHOOSER_PORTFOLIO"));
  }
  const std::string mpath = Field(Field(path, "auto"), "members");
  auto* members = auto_config->mutable_members();
  if (members->empty()) {
    const bool bounds = config->state_bounds_size() == config->state_dim();
    for (plan::Strategy member :
         plan::DefaultAutoMembers(bounds, EngineChooser(auto_config->chooser()))) {
      members->Add(WireStrategy(member));
    }
    return absl::OkStatus();
  }
  std::vector<plan::Strategy> engine;
  for (int i = 0; i < members->size(); ++i) {
    const auto member = static_cast<v1::Strategy>(members->Get(i));
    if (member == v1::STRATEGY_UNSPECIFIED || !v1::Strategy_IsValid(member)) {
      return Invalid(absl::StrCat(mpath, "[", i, "]"),
                     absl::StrCat("unknown strategy ", static_cast<int>(member),
                                  "; valid: ", ValidStrategyNames()));
    }
    engine.push_back(EngineStrategy(member).strategy);
  }
  bool repeated = false;
  const int bad = plan::FirstBadAutoMember(engine, &repeated);
  if (bad < 0) return absl::OkStatus();
  const std::string name = v1::Strategy_Name(members->Get(bad));
  return Invalid(absl::StrCat(mpath, "[", bad, "]"),
                 repeated ? absl::StrCat(name, " is named twice")
                          : absl::StrCat(name,
                                         " cannot be a member of STRATEGY_AUTO (pa would "
                                         "be rec inside it, sep's plans must be applied "
                                         "whole); any other strategy can"));
}

// The state_bounds a strategy needs (StrategyInfo::needs_state_bounds: sep's
// search box, roi's reference set), auto's members' included.
absl::Status ValidateStrategyNeeds(absl::string_view path,
                                   const v1::SessionConfig& config) {
  if (config.state_bounds_size() == config.state_dim()) return absl::OkStatus();
  for (const plan::StrategyInfo* info : StrategiesInUse(config)) {
    if (!info->needs_state_bounds) continue;
    return Invalid(
        Field(path, "state_bounds"),
        absl::StrCat(
            v1::Strategy_Name(WireStrategy(info->strategy)),
            config.strategy() == v1::STRATEGY_AUTO ? " (a member of STRATEGY_AUTO)" : "",
            " needs state_dim (", config.state_dim(),
            ") intervals (its region is state_bounds x "
            "input_bounds), got ",
            config.state_bounds_size()));
  }
  return absl::OkStatus();
}

// Whether the config plans with a strategy that reads config block `block`.
bool UsesBlock(const v1::SessionConfig& config, absl::string_view block) {
  for (const plan::StrategyInfo* info : StrategiesInUse(config)) {
    if (info->config_block == block) return true;
  }
  return false;
}

// OptimisticConfig: beta in (0, 10] when set; filled in (1) for
// STRATEGY_OPTIMISTIC (alone or as a member of STRATEGY_AUTO).
absl::Status ValidateOptimistic(absl::string_view path, v1::SessionConfig* config) {
  const bool optimistic = UsesBlock(*config, "optimistic");
  if (config->optimistic().has_beta()) {
    const double beta = config->optimistic().beta();
    if (!std::isfinite(beta) || !(beta > 0.0) || beta > 10.0) {
      return Invalid(Field(Field(path, "optimistic"), "beta"),
                     absl::StrCat("must be in (0, 10] standard deviations, got ", beta));
    }
  } else if (optimistic) {
    config->mutable_optimistic()->set_beta(plan::PlanOptions().optimism_beta);
  }
  return absl::OkStatus();
}

// SparseConfig: MI and ROI need the exact GP's joint covariances, so they stay
// exact; the other strategies default to sparse above kDefaultSparseAboveSamples.
absl::Status ValidateSparse(absl::string_view path, v1::SessionConfig* config) {
  const std::string spath = Field(path, "sparse");
  v1::SparseConfig* sparse = config->mutable_sparse();
  bool joint = false;
  for (const plan::StrategyInfo* info : StrategiesInUse(*config)) {
    joint = joint || info->needs_joint_covariances;
  }
  if (!sparse->has_above_samples()) {
    sparse->set_above_samples(joint ? 0 : kDefaultSparseAboveSamples);
  }
  const int32_t above = sparse->above_samples();
  if (joint && above != 0) {
    return Invalid(
        Field(spath, "above_samples"),
        absl::StrCat("must be 0 (never sparse) for ",
                     v1::Strategy_Name(config->strategy()),
                     ", which needs the exact GP's joint covariances; got ", above));
  }
  if (above != 0 && (above < kMinSparseAboveSamples || above > kMaxSparseAboveSamples)) {
    return Invalid(
        Field(spath, "above_samples"),
        absl::StrCat("must be 0 (never sparse) or in [", kMinSparseAboveSamples, ", ",
                     kMaxSparseAboveSamples, "], got ", above));
  }
  // max_inducing and fit_samples: config_rules.cc.
  const gp::SparseGpOptions defaults;
  const double tolerance = sparse->inducing_tolerance();
  if (tolerance != 0.0 && !(tolerance >= 1e-6 && tolerance <= 1e6)) {
    return Invalid(Field(spath, "inducing_tolerance"),
                   absl::StrCat("must be 0 (default ", defaults.inducing_tolerance,
                                ") or in [1e-6, 1e6] noise variances, got ", tolerance));
  }
  if (above > 0 && tolerance == 0.0) {
    sparse->set_inducing_tolerance(defaults.inducing_tolerance);
  }
  return absl::OkStatus();
}

// angle_dims: state dimensions, each once, with the delta target.
absl::Status ValidateAngles(absl::string_view path, const v1::SessionConfig& config) {
  std::vector<bool> seen(config.state_dim(), false);
  for (int i = 0; i < config.angle_dims_size(); ++i) {
    const int a = config.angle_dims(i);
    if (a < 0 || a >= config.state_dim()) {
      return Invalid(Indexed(path, "angle_dims", i),
                     absl::StrCat("must be a state dimension in [0, ", config.state_dim(),
                                  "), got ", a));
    }
    if (seen[a]) {
      return Invalid(Indexed(path, "angle_dims", i),
                     absl::StrCat("names state ", a, " twice"));
    }
    seen[a] = true;
  }
  if (config.angle_dims_size() > 0 && config.target() == v1::TARGET_NEXT) {
    return Invalid(Field(path, "target"),
                   "angle_dims need TARGET_DELTA: a next angle is only known up to a "
                   "turn, its difference is not");
  }
  return absl::OkStatus();
}

// A dimension's name: 1-32 letters, digits and _, starting with a letter.
bool IsDimensionName(absl::string_view name) {
  return !name.empty() && name.size() <= 32 && absl::ascii_isalpha(name[0]) &&
         std::all_of(name.begin(), name.end(),
                     [](char c) { return absl::ascii_isalnum(c) || c == '_'; });
}

// A unit: at most 16 printable ASCII characters.
bool IsUnit(absl::string_view unit) {
  return unit.size() <= 16 && std::all_of(unit.begin(), unit.end(),
                                          [](char c) { return c >= 0x20 && c < 0x7F; });
}

// state_names, input_names, state_units, input_units: empty or one per
// dimension; names all different.
absl::Status ValidateNames(absl::string_view path, const v1::SessionConfig& config) {
  struct List {
    const char* field;
    const google::protobuf::RepeatedPtrField<std::string>& values;
    int dim;
    bool names;
  };
  const List lists[] = {{"state_names", config.state_names(), config.state_dim(), true},
                        {"input_names", config.input_names(), config.input_dim(), true},
                        {"state_units", config.state_units(), config.state_dim(), false},
                        {"input_units", config.input_units(), config.input_dim(), false}};
  std::vector<std::string> seen;
  for (const List& list : lists) {
    if (!list.values.empty() && list.values.size() != list.dim) {
      return Invalid(Field(path, list.field),
                     absl::StrCat("must be empty or have one entry per dimension (",
                                  list.dim, "), got ", list.values.size()));
    }
    for (int i = 0; i < list.values.size(); ++i) {
      const std::string& v = list.values.Get(i);
      if (!(list.names ? IsDimensionName(v) : IsUnit(v))) {
        return Invalid(Indexed(path, list.field, i),
                       absl::StrCat(list.names ? "a name is 1-32 letters, digits and _, "
                                                 "starting with a letter"
                                               : "a unit is at most 16 printable ASCII "
                                                 "characters",
                                    ", got \"", v.substr(0, 40), "\""));
      }
      if (!list.names) continue;
      if (std::find(seen.begin(), seen.end(), v) != seen.end()) {
        return Invalid(Indexed(path, list.field, i),
                       absl::StrCat("\"", v, "\" names two dimensions"));
      }
      seen.push_back(v);
    }
  }
  return absl::OkStatus();
}

// SafetyConfig: 0 or state_dim intervals; the margin filled in (2) when a box
// is set.
absl::Status ValidateSafety(absl::string_view path, v1::SessionConfig* config) {
  if (!config->has_safety()) return absl::OkStatus();
  const std::string spath = Field(path, "safety");
  v1::SafetyConfig* safety = config->mutable_safety();
  if (safety->state_bounds_size() != 0 &&
      safety->state_bounds_size() != config->state_dim()) {
    return Invalid(Field(spath, "state_bounds"),
                   absl::StrCat("must have 0 or state_dim (", config->state_dim(),
                                ") entries, got ", safety->state_bounds_size()));
  }
  for (int i = 0; i < safety->state_bounds_size(); ++i) {
    if (absl::Status s =
            CheckDataInterval(Indexed(spath, "state_bounds", i), safety->state_bounds(i));
        !s.ok()) {
      return s;
    }
  }
  for (int a : config->angle_dims()) {
    if (a < 0 || a >= safety->state_bounds_size()) continue;  // ValidateAngles says
    const v1::Interval& b = safety->state_bounds(a);
    if (b.upper() - b.lower() < 2.0 * kPi) {
      return Invalid(Indexed(spath, "state_bounds", a),
                     absl::StrCat("state ", a,
                                  " is an angle (angle_dims): its values wrap, so a box "
                                  "narrower than one turn cannot hold it; give at least "
                                  "[-pi, pi] (it then constrains nothing), got [",
                                  b.lower(), ", ", b.upper(), "]"));
    }
  }
  if (safety->has_margin() &&
      !(std::isfinite(safety->margin()) && safety->margin() >= 0.0 &&
        safety->margin() <= kMaxSafetyMargin)) {
    return Invalid(Field(spath, "margin"),
                   absl::StrCat("must be finite in [0, ", kMaxSafetyMargin,
                                "] standard deviations, got ", safety->margin()));
  }
  if (safety->state_bounds_size() > 0 && !safety->has_margin()) {
    safety->set_margin(plan::SafeBox().margin);
  }
  return absl::OkStatus();
}

}  // namespace

int KernelInputs(const v1::SessionConfig& config) {
  return config.state_dim() + config.input_dim() + config.angle_dims_size();
}

absl::Status ValidateHyperparameters(absl::string_view path,
                                     const v1::Hyperparameters& hyperparameters,
                                     int kernel_inputs) {
  const v1::Hyperparameters& h = hyperparameters;
  if (absl::Status s = CheckPositive(Field(path, "signal_variance"), h.signal_variance(),
                                     kMinHyperVariance, kMaxHyperVariance);
      !s.ok()) {
    return s;
  }
  if (h.lengthscales_size() != kernel_inputs) {
    return Invalid(Field(path, "lengthscales"),
                   absl::StrCat("must have state_dim + input_dim + one per angle (",
                                kernel_inputs, ") entries, got ", h.lengthscales_size()));
  }
  for (int l = 0; l < h.lengthscales_size(); ++l) {
    if (absl::Status s =
            CheckPositive(Indexed(path, "lengthscales", l), h.lengthscales(l),
                          kMinLengthscale, kMaxLengthscale);
        !s.ok()) {
      return s;
    }
  }
  return CheckPositive(Field(path, "noise_variance"), h.noise_variance(),
                       kMinHyperVariance, kMaxHyperVariance);
}

absl::Status ValidateSessionConfig(v1::SessionConfig* config, absl::string_view path) {
  // Every independent problem is reported (one field violation each); checks that
  // count entries per dimension run only with valid dimensions.
  Violations problems;
  bool dims_ok = true;
  if (config->state_dim() < 1 || config->state_dim() > kMaxStateDim) {
    problems.Add(Invalid(
        Field(path, "state_dim"),
        absl::StrCat("must be in [1, ", kMaxStateDim, "], got ", config->state_dim())));
    dims_ok = false;
  }
  if (config->input_dim() < 1 || config->input_dim() > kMaxInputDim) {
    problems.Add(Invalid(
        Field(path, "input_dim"),
        absl::StrCat("must be in [1, ", kMaxInputDim, "], got ", config->input_dim())));
    dims_ok = false;
  }
  if (dims_ok && config->input_bounds_size() != config->input_dim()) {
    problems.Add(Invalid(Field(path, "input_bounds"),
                         absl::StrCat("must have input_dim (", config->input_dim(),
                                      ") entries, got ", config->input_bounds_size())));
  }
  for (int i = 0; i < config->input_bounds_size(); ++i) {
    problems.Add(
        CheckDataInterval(Indexed(path, "input_bounds", i), config->input_bounds(i)));
  }
  if (dims_ok && config->state_bounds_size() != 0 &&
      config->state_bounds_size() != config->state_dim()) {
    problems.Add(Invalid(Field(path, "state_bounds"),
                         absl::StrCat("must have 0 or state_dim (", config->state_dim(),
                                      ") entries, got ", config->state_bounds_size())));
  }
  for (int i = 0; i < config->state_bounds_size(); ++i) {
    problems.Add(
        CheckDataInterval(Indexed(path, "state_bounds", i), config->state_bounds(i)));
  }

  const std::string npath = Field(path, "noise");
  problems.Add(CheckPositive(Field(npath, "variance"), config->noise().variance(),
                             kMinNoiseVariance, kMaxNoiseVariance));
  // Unset kernel.fit: fitted unless fixed hyperparameters are given (a minimal
  // config works; a config with `fixed` means them). Filled in before the noise
  // check, which depends on it.
  if (!config->kernel().has_fit()) {
    config->mutable_kernel()->set_fit(config->kernel().fixed_size() == 0);
  }
  if (config->noise().fit() && !config->kernel().fit()) {
    problems.Add(
        Invalid(Field(npath, "fit"),
                "the noise variance can only be fitted when kernel.fit is true (with "
                "kernel.fit false, kernel.fixed[i].noise_variance is used)"));
  }
  if (dims_ok) problems.Add(ValidateAngles(path, *config));
  if (dims_ok) problems.Add(ValidateNames(path, *config));
  if (dims_ok) problems.Add(ValidateKernel(path, *config, config->mutable_kernel()));

  if (config->target() == v1::TARGET_UNSPECIFIED) config->set_target(v1::TARGET_DELTA);
  if (config->target() != v1::TARGET_DELTA && config->target() != v1::TARGET_NEXT) {
    problems.Add(
        Invalid(Field(path, "target"),
                absl::StrCat("unknown value ", static_cast<int>(config->target()),
                             "; valid: TARGET_DELTA, TARGET_NEXT")));
  }
  if (config->prior_mean() == v1::PRIOR_MEAN_UNSPECIFIED) {
    config->set_prior_mean(v1::PRIOR_MEAN_CONSTANT);
  }
  if (!v1::PriorMean_IsValid(config->prior_mean())) {
    problems.Add(
        Invalid(Field(path, "prior_mean"),
                absl::StrCat("unknown value ", static_cast<int>(config->prior_mean()),
                             "; valid: PRIOR_MEAN_CONSTANT, PRIOR_MEAN_LINEAR")));
  }
  if (config->strategy() == v1::STRATEGY_UNSPECIFIED) {
    config->set_strategy(v1::STRATEGY_REC);
  }
  if (!v1::Strategy_IsValid(config->strategy())) {
    problems.Add(
        Invalid(Field(path, "strategy"),
                absl::StrCat("unknown value ", static_cast<int>(config->strategy()),
                             "; valid: ", ValidStrategyNames())));
  }
  const std::string rpath = Field(path, "refit");
  v1::RefitPolicy* refit = config->mutable_refit();
  if (!refit->has_growth()) {
    refit->set_growth(kDefaultRefitGrowth);
  } else if (!(std::isfinite(refit->growth()) && refit->growth() >= 0.0 &&
               refit->growth() <= 10.0)) {
    problems.Add(
        Invalid(Field(rpath, "growth"),
                absl::StrCat("must be a fraction of the fitted samples in [0, 10], "
                             "got ",
                             refit->growth())));
  }
  if (v1::Strategy_IsValid(config->strategy())) problems.Add(ValidateAuto(path, config));
  if (dims_ok) {
    problems.Add(ValidateStrategyNeeds(path, *config));
    problems.Add(ValidateOptimistic(path, config));
    problems.Add(ValidateSafety(path, config));
  }
  problems.Add(ValidateSparse(path, config));
  // Every number whose 0 means a default: the table (config_rules.cc).
  ApplyNumberRules(config, path, &problems);
  // A strategy with a fixed horizon (greedy: 1) overrides a valid one.
  if (const int fixed = EngineStrategy(config->strategy()).fixed_horizon;
      fixed > 0 && config->horizon() >= 1 && config->horizon() <= kMaxHorizon) {
    config->set_horizon(fixed);
  }
  return problems.Result();
}

absl::StatusOr<v1::SessionConfig> ValidatedSessionConfig(const v1::SessionConfig& config,
                                                         absl::string_view path) {
  v1::SessionConfig copy = config;
  if (absl::Status s = ValidateSessionConfig(&copy, path); !s.ok()) return s;
  return copy;
}

}  // namespace excite::service
