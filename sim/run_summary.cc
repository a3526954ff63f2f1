#include "sim/run_summary.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace excite::sim {
namespace {

std::string JsonNumber(double value) {
  if (!std::isfinite(value)) return "null";
  return absl::StrFormat("%.17g", value);
}

std::string JsonString(const std::string& text) {
  std::string out = "\"";
  for (const char c : text) {
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\t':
        out += "\\t";
        break;
      case '\r':
        out += "\\r";
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          out += absl::StrFormat("\\u%04x", static_cast<int>(c));
        } else {
          out += c;
        }
    }
  }
  out += "\"";
  return out;
}

}  // namespace

std::string RunSummaryToJson(const RunSummary& summary) {
  std::string history = "[";
  for (size_t i = 0; i < summary.rmse_history.size(); ++i) {
    absl::StrAppend(&history, i == 0 ? "" : ", ", "[", summary.rmse_history[i].samples,
                    ", ", JsonNumber(summary.rmse_history[i].rmse), "]");
  }
  history += "]";
  std::string per_dimension = "[";
  for (size_t j = 0; j < summary.final_rmse_per_dimension.size(); ++j) {
    absl::StrAppend(&per_dimension, j == 0 ? "" : ", ",
                    JsonNumber(summary.final_rmse_per_dimension[j]));
  }
  per_dimension += "]";
  const auto strings = [](const std::vector<std::string>& values) {
    std::string out = "[";
    for (size_t i = 0; i < values.size(); ++i) {
      absl::StrAppend(&out, i == 0 ? "" : ", ", JsonString(values[i]));
    }
    return out + "]";
  };
  const std::string joint =
      summary.coverage_joint.has_value() ? JsonNumber(*summary.coverage_joint) : "null";
  const std::string left_safe_box =
      summary.left_safe_box.has_value() ? JsonNumber(*summary.left_safe_box) : "null";
  std::string planned_by = "{";
  for (const auto& [name, count] : summary.planned_by) {
    absl::StrAppend(&planned_by, planned_by.size() > 1 ? ", " : "", JsonString(name),
                    ": ", count);
  }
  planned_by += "}";
  const RealtimeStats& rt = summary.realtime;
  const std::string realtime =
      rt.hz > 0 ? absl::StrCat("{\"hz\": ", JsonNumber(rt.hz),
                               ", \"ticks_from_plan\": ", rt.ticks_from_plan,
                               ", \"ticks_fell_back\": ", rt.ticks_fell_back,
                               ", \"late_plans\": ", rt.late_plans,
                               ", \"overruns\": ", rt.overruns, "}")
                : "null";
  return absl::StrCat(
      "{\n",                                                    //
      "  \"system\": ", JsonString(summary.system), ",\n",      //
      "  \"strategy\": ", JsonString(summary.strategy), ",\n",  //
      "  \"session\": ", JsonString(summary.session), ",\n",    //
      "  \"samples\": ", summary.samples, ",\n",                //
      "  \"final_rmse\": ", JsonNumber(summary.final_rmse), ",\n",
      "  \"final_rmse_per_dimension\": ", per_dimension, ",\n",
      "  \"state_names\": ", strings(summary.state_names), ",\n",
      "  \"state_units\": ", strings(summary.state_units), ",\n",
      "  \"final_nlpd\": ", JsonNumber(summary.final_nlpd), ",\n",
      "  \"final_inside_95\": ", JsonNumber(summary.final_inside_95), ",\n",
      "  \"rollout_rmse_10\": ", JsonNumber(summary.rollout_rmse_10), ",\n",
      "  \"rollout_rmse_30\": ", JsonNumber(summary.rollout_rmse_30), ",\n",
      "  \"midway_samples\": ", summary.midway_samples, ",\n",
      "  \"midway_rmse\": ", JsonNumber(summary.midway_rmse), ",\n",
      "  \"midway_rollout_rmse_10\": ", JsonNumber(summary.midway_rollout_rmse_10), ",\n",
      "  \"midway_rollout_rmse_30\": ", JsonNumber(summary.midway_rollout_rmse_30), ",\n",
      "  \"coverage_marginal\": ", JsonNumber(summary.coverage_marginal),
      ",\n",                                   //
      "  \"coverage_joint\": ", joint, ",\n",  //
      "  \"rmse_history\": ", history, ",\n",  //
      "  \"plan_ms_p50\": ", JsonNumber(summary.plan_ms_p50), ",\n",
      "  \"plans\": ", summary.plans, ",\n",                //
      "  \"planned_by\": ", planned_by, ",\n",              //
      "  \"random_steps\": ", summary.random_steps, ",\n",  //
      "  \"plan_retries\": ", summary.plan_retries, ",\n",  //
      "  \"left_safe_box\": ", left_safe_box, ",\n",        //
      "  \"wall_s\": ", JsonNumber(summary.wall_s), ",\n",  //
      "  \"plan_ms_p90\": ", JsonNumber(summary.plan_ms_p90), ",\n",
      "  \"plan_ms_p99\": ", JsonNumber(summary.plan_ms_p99), ",\n",
      "  \"realtime\": ", realtime, "\n",  //
      "}\n");
}

absl::Status WriteRunSummary(const RunSummary& summary, const std::string& path) {
  std::ofstream file(path, std::ios::trunc);
  if (!file)
    return absl::InternalError(absl::StrCat("cannot open ", path, " for writing"));
  file << RunSummaryToJson(summary);
  file.close();
  if (!file) return absl::InternalError(absl::StrCat("cannot write ", path));
  return absl::OkStatus();
}

double Median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  const size_t mid = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + mid, values.end());
  const double upper = values[mid];
  if (values.size() % 2 == 1) return upper;
  const double lower = *std::max_element(values.begin(), values.begin() + mid);
  return 0.5 * (lower + upper);
}

double Quantile(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const double position =
      std::clamp(q, 0.0, 1.0) * static_cast<double>(values.size() - 1);
  const size_t below = static_cast<size_t>(position);
  const size_t above = std::min(below + 1, values.size() - 1);
  const double fraction = position - static_cast<double>(below);
  return values[below] + fraction * (values[above] - values[below]);
}

}  // namespace excite::sim
