#include "client/transition_csv.h"

#include <cmath>
#include <map>
#include <utility>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_split.h"

namespace excite::client {
namespace {

bool IsName(absl::string_view field) {
  double unused = 0.0;
  return !field.empty() && (absl::ascii_isalpha(field[0]) || field[0] == '_') &&
         !absl::SimpleAtod(field, &unused);
}

std::vector<absl::string_view> Fields(absl::string_view line) {
  std::vector<absl::string_view> fields = absl::StrSplit(line, ',');
  for (absl::string_view& f : fields) f = absl::StripAsciiWhitespace(f);
  return fields;
}

}  // namespace

std::string TransitionCsvHeader(int dx, int du,
                                const std::vector<std::string>& state_names,
                                const std::vector<std::string>& input_names) {
  const bool named = state_names.size() == static_cast<size_t>(dx) &&
                     input_names.size() == static_cast<size_t>(du);
  const auto x = [&](int i) { return named ? state_names[i] : absl::StrCat("x", i); };
  std::string header;
  for (int i = 0; i < dx; ++i) absl::StrAppend(&header, i == 0 ? "" : ",", x(i));
  for (int j = 0; j < du; ++j) {
    absl::StrAppend(&header, ",", named ? input_names[j] : absl::StrCat("u", j));
  }
  for (int i = 0; i < dx; ++i) absl::StrAppend(&header, ",", x(i), "_next");
  absl::StrAppend(&header, ",sequence");
  return header;
}

std::string TransitionCsvRow(const v1::Transition& transition) {
  std::string row;
  const auto append = [&row](double v) {
    absl::StrAppend(&row, row.empty() ? "" : ",", absl::StrFormat("%.17g", v));
  };
  for (double v : transition.state()) append(v);
  for (double v : transition.input()) append(v);
  for (double v : transition.next_state()) append(v);
  absl::StrAppend(&row, ",", transition.sequence());
  return row;
}

absl::StatusOr<CsvHeader> ParseCsvHeaderMode(absl::string_view text) {
  if (text == "auto") return CsvHeader::kAuto;
  if (text == "yes") return CsvHeader::kYes;
  if (text == "no") return CsvHeader::kNo;
  return absl::InvalidArgumentError(
      absl::StrCat("--header must be auto, yes or no, got \"", text, "\""));
}

absl::StatusOr<std::vector<v1::Transition>> ParseTransitionCsv(absl::string_view text,
                                                               int dx, int du,
                                                               int64_t next_sequence,
                                                               CsvHeader header) {
  const size_t columns = static_cast<size_t>(2 * dx + du);
  const std::string want =
      absl::StrCat("want ", columns, " comma-separated numbers (x: ", dx, ", u: ", du,
                   ", x_next: ", dx, ") and optionally an integer sequence number");
  std::vector<v1::Transition> transitions;
  std::map<int64_t, int> line_of_sequence;
  bool first_row = true;
  int line_number = 0;
  for (absl::string_view line : absl::StrSplit(text, '\n')) {
    ++line_number;
    line = absl::StripAsciiWhitespace(line);
    if (line.empty() || absl::StartsWith(line, "#")) continue;
    const std::vector<absl::string_view> fields = Fields(line);
    if (first_row) {
      first_row = false;
      bool names = true;
      for (absl::string_view f : fields) names = names && IsName(f);
      if (header == CsvHeader::kYes || (header == CsvHeader::kAuto && names)) {
        if (fields.size() != columns && fields.size() != columns + 1) {
          return absl::InvalidArgumentError(
              absl::StrCat("line ", line_number, ": the header has ", fields.size(),
                           " columns; ", want));
        }
        continue;
      }
    }
    if (fields.size() != columns && fields.size() != columns + 1) {
      return absl::InvalidArgumentError(
          absl::StrCat("line ", line_number, ": ", want, ", found ", fields.size(),
                       " field", fields.size() == 1 ? "" : "s", " in \"", line, "\"",
                       fields.size() == 1 && absl::StrContains(line, ' ')
                           ? " (separated by spaces? separate them by commas)"
                           : ""));
    }
    std::vector<double> values(fields.size());
    for (size_t c = 0; c < fields.size(); ++c) {
      if (!absl::SimpleAtod(fields[c], &values[c]) || !std::isfinite(values[c])) {
        return absl::InvalidArgumentError(absl::StrCat("line ", line_number, ", column ",
                                                       c + 1, ": \"", fields[c],
                                                       "\" is not a finite number"));
      }
    }
    v1::Transition t;
    t.mutable_state()->Add(values.begin(), values.begin() + dx);
    t.mutable_input()->Add(values.begin() + dx, values.begin() + dx + du);
    t.mutable_next_state()->Add(values.begin() + dx + du, values.begin() + columns);
    if (fields.size() == columns + 1) {
      int64_t sequence = 0;
      if (!absl::SimpleAtoi(fields.back(), &sequence) || sequence < 0) {
        return absl::InvalidArgumentError(
            absl::StrCat("line ", line_number, ": the sequence number \"", fields.back(),
                         "\" is not an integer >= 0"));
      }
      t.set_sequence(sequence);
    } else {
      t.set_sequence(next_sequence++);
    }
    const auto [at, inserted] = line_of_sequence.emplace(t.sequence(), line_number);
    if (!inserted) {
      return absl::InvalidArgumentError(absl::StrCat("line ", line_number,
                                                     ": sequence number ", t.sequence(),
                                                     " is also on line ", at->second));
    }
    transitions.push_back(std::move(t));
  }
  if (transitions.empty()) {
    return absl::InvalidArgumentError(
        "no transitions: every line is blank, a comment "
        "or the header");
  }
  return transitions;
}

}  // namespace excite::client
