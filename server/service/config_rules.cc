#include "server/service/config_rules.h"

#include <cmath>
#include <cstdint>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "google/protobuf/descriptor.h"
#include "google/protobuf/message.h"
#include "server/gp/dynamics_model.h"
#include "server/gp/hyperparameter_fit.h"
#include "server/gp/sparse_gp_model.h"
#include "server/plan/plan_types.h"
#include "server/service/config_validation.h"
#include "server/service/field_violation.h"
#include "server/service/strategy_names.h"
#include "server/service/value_ranges.h"

namespace excite::service {
namespace {

using google::protobuf::FieldDescriptor;
using google::protobuf::Message;

NumberRule Rule(absl::string_view path, double default_value, double min, double max,
                absl::string_view why) {
  NumberRule rule;
  rule.path = path;
  rule.default_value = default_value;
  rule.min = min;
  rule.max = max;
  rule.why = why;
  return rule;
}

NumberRule For(NumberRule rule, absl::string_view filled_for) {
  rule.filled_for = filled_for;
  return rule;
}

// Both ends excluded.
NumberRule Open(NumberRule rule) {
  rule.min_open = rule.max_open = true;
  return rule;
}

NumberRule Seconds(NumberRule rule) {
  rule.unit = " seconds";
  return rule;
}

// A frequency in cycles per sample: (0, 0.5], 0.5 being the Nyquist frequency.
NumberRule Frequency(NumberRule rule) {
  rule.min_open = true;
  rule.unit = " cycles per sample";
  return rule;
}

std::vector<NumberRule> MakeRules() {
  const gp::FitOptions fit;
  const plan::PlanOptions plan;
  const plan::SignalOptions& signal = plan.signal;
  const plan::SepOptions& sep = plan.sep;
  const gp::SparseGpOptions sparse;
  return {
      Rule("kernel.restarts", fit.restarts, 0, kMaxFitRestarts,
           "ML-II random restarts on top of the warm start; each costs O(n^3) per "
           "iteration"),
      Rule("kernel.max_iterations", fit.max_iterations, 1, kMaxFitIterations,
           "L-BFGS-B iterations per restart"),
      Rule("horizon", plan.horizon, 1, kMaxHorizon,
           "M, the planned inputs per call (paper: 15; greedy forces 1)"),
      Rule("refit.every_samples", kDefaultRefitEverySamples, 1, 1000000,
           "a refit needs this many new samples since the last fit"),
      Rule("refit.min_samples", kDefaultMinSamples, 2, 1000000,
           "Predict and PlanInputs need this many samples (a fit needs 2)"),
      For(Rule("signal.prbs_min_hold", signal.prbs_min_hold, 1, 1000000,
               "samples per PRBS clock period"),
          "prbs"),
      For(Frequency(Rule("signal.chirp_start_frequency", signal.chirp_start_frequency, 0,
                         0.5,
                         "cycles per sample at the start of a sweep (0.5: Nyquist)")),
          "chirp"),
      For(Frequency(Rule("signal.chirp_end_frequency", signal.chirp_end_frequency, 0, 0.5,
                         "cycles per sample at the end of a sweep")),
          "chirp"),
      For(Rule("signal.chirp_period", signal.chirp_period, 1, 1000000,
               "samples per sweep (the sweep repeats)"),
          "chirp"),
      For(Rule("signal.random_hold", signal.random_hold, 1, 1000000,
               "samples each random input is held"),
          "random"),
      For(Rule("sep.search_starts", sep.search_starts, 1, 100,
               "L-BFGS-B starts of sep's search for z*"),
          "sep"),
      For(Rule("sep.search_samples", sep.search_samples, 1, 100000,
               "random samples the first start is picked from"),
          "sep"),
      For(Rule("sep.search_iterations", sep.search_iterations, 1, 10000,
               "L-BFGS-B iterations per start"),
          "sep"),
      For(Rule("roi.reference_points", plan.roi_reference_points, 1, 4096,
               "Halton points of roi's reference set (its cost grows with them)"),
          "roi"),
      For(Rule("sparse.max_inducing", sparse.max_inducing, 1, kMaxInducingPoints,
               "inducing points of a sparse output"),
          "sparse"),
      For(Rule("sparse.fit_samples", gp::DynamicsModelOptions().sparse_fit_samples,
               kMinSparseAboveSamples, kMaxSparseFitSamples,
               "samples a sparse output's hyperparameters are fitted on"),
          "sparse"),
      Rule("planner.max_iterations", plan.max_iterations, 1, 10000,
           "Ipopt iterations per start"),
      Rule("planner.restarts", plan.restarts, 0, 100,
           "random starts on top of the warm start"),
      Open(Rule("planner.tolerance", plan.tolerance, 0, 1, "Ipopt's tol")),
      Seconds(Rule("planner.time_budget_s", kDefaultTimeBudgetS, kMinTimeBudgetS,
                   kMaxTimeBudgetS,
                   "a call's refit and plan; the client's deadline also applies")),
  };
}

// The field at `path` (dot-separated) under `root`: the message holding it (read
// only; mutable only when `mutable_parents`) and its descriptor. nullptr if the
// path names no such field (a bug in the table: the caller aborts the check).
const FieldDescriptor* Resolve(const Message& root, absl::string_view path,
                               const Message** holder) {
  const Message* message = &root;
  const FieldDescriptor* field = nullptr;
  const std::vector<absl::string_view> parts = absl::StrSplit(path, '.');
  for (size_t i = 0; i < parts.size(); ++i) {
    field = message->GetDescriptor()->FindFieldByName(std::string(parts[i]));
    if (field == nullptr) return nullptr;
    if (i + 1 < parts.size()) {
      if (field->cpp_type() != FieldDescriptor::CPPTYPE_MESSAGE) return nullptr;
      message = &message->GetReflection()->GetMessage(*message, field);
    }
  }
  *holder = message;
  return field;
}

Message* MutableHolder(Message* root, absl::string_view path) {
  Message* message = root;
  const std::vector<absl::string_view> parts = absl::StrSplit(path, '.');
  for (size_t i = 0; i + 1 < parts.size(); ++i) {
    const FieldDescriptor* field =
        message->GetDescriptor()->FindFieldByName(std::string(parts[i]));
    message = message->GetReflection()->MutableMessage(message, field);
  }
  return message;
}

bool IsInt(const FieldDescriptor& field) {
  return field.cpp_type() == FieldDescriptor::CPPTYPE_INT32;
}

std::string Number(double value, bool as_int) {
  return as_int ? absl::StrCat(static_cast<int64_t>(value)) : absl::StrCat(value);
}

std::string Range(const NumberRule& rule, bool as_int) {
  return absl::StrCat(rule.min_open ? "(" : "[", Number(rule.min, as_int), ", ",
                      Number(rule.max, as_int), rule.max_open ? ")" : "]");
}

bool InRange(const NumberRule& rule, double value) {
  return std::isfinite(value) && (rule.min_open ? value > rule.min : value >= rule.min) &&
         (rule.max_open ? value < rule.max : value <= rule.max);
}

bool Fills(const NumberRule& rule, const v1::SessionConfig& config) {
  if (rule.filled_for.empty()) return true;
  if (rule.filled_for == "sparse") return config.sparse().above_samples() > 0;
  for (const plan::StrategyInfo* info : StrategiesInUse(config)) {
    if (info->name == rule.filled_for) return true;
  }
  return false;
}

}  // namespace

absl::Span<const NumberRule> NumberRules() {
  static const std::vector<NumberRule>* const rules =
      new std::vector<NumberRule>(MakeRules());
  return *rules;
}

void ApplyNumberRules(v1::SessionConfig* config, absl::string_view path,
                      Violations* problems) {
  for (const NumberRule& rule : NumberRules()) {
    const Message* holder = nullptr;
    const FieldDescriptor* field = Resolve(*config, rule.path, &holder);
    if (field == nullptr) {
      problems->Add(absl::InternalError(
          absl::StrCat("config rule for an unknown field ", rule.path)));
      continue;
    }
    const bool as_int = IsInt(*field);
    const google::protobuf::Reflection* reflection = holder->GetReflection();
    const double set = as_int ? reflection->GetInt32(*holder, field)
                              : reflection->GetDouble(*holder, field);
    const double value = set == 0.0 ? rule.default_value : set;
    if (!InRange(rule, value)) {
      problems->Add(FieldViolationError(
          absl::StrCat(path, ".", rule.path),
          absl::StrCat("must be in ", Range(rule, as_int), rule.unit,
                       " (0 for the default ", Number(rule.default_value, as_int),
                       "), got ", Number(value, as_int))));
      continue;
    }
    if (set != 0.0 || !Fills(rule, *config)) continue;
    Message* target = MutableHolder(config, rule.path);
    if (as_int) {
      target->GetReflection()->SetInt32(target, field,
                                        static_cast<int32_t>(rule.default_value));
    } else {
      target->GetReflection()->SetDouble(target, field, rule.default_value);
    }
  }
}

std::string NumberRulesMarkdown() {
  std::string out =
      "| field | 0 means | valid | default filled in for | why |\n"
      "| --- | --- | --- | --- | --- |\n";
  for (const NumberRule& rule : NumberRules()) {
    const Message* holder = nullptr;
    const FieldDescriptor* field =
        Resolve(v1::SessionConfig::default_instance(), rule.path, &holder);
    const bool as_int = field != nullptr && IsInt(*field);
    const std::string filled_for =
        rule.filled_for.empty()
            ? std::string("every session")
            : absl::StrCat(rule.filled_for == "sparse" ? "sparse" : rule.filled_for,
                           " sessions");
    absl::StrAppend(&out, "| `", rule.path, "` | ", Number(rule.default_value, as_int),
                    " | ", Range(rule, as_int), rule.unit, " | ", filled_for, " | ",
                    rule.why, " |\n");
  }
  return out;
}

}  // namespace excite::service
