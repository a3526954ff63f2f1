#include "server/service/session_labels.h"

#include <utility>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "server/service/field_violation.h"

namespace excite::service {
namespace {

constexpr size_t kMaxDisplayName = 256;
constexpr size_t kMaxLabels = 64;
constexpr size_t kMaxLabelPart = 63;

bool IsLabelChar(char c) {
  return absl::ascii_islower(c) || absl::ascii_isdigit(c) || c == '_' || c == '-';
}

bool IsLabelText(absl::string_view text) {
  for (char c : text) {
    if (!IsLabelChar(c)) return false;
  }
  return text.size() <= kMaxLabelPart;
}

bool IsLabelKey(absl::string_view key) {
  return !key.empty() && absl::ascii_islower(key.front()) && IsLabelText(key);
}

constexpr char kFilterSyntax[] =
    "conditions joined by AND, each labels.KEY = \"VALUE\", labels.KEY != \"VALUE\" or "
    "labels.KEY:*";

absl::Status FilterError(absl::string_view condition, absl::string_view problem) {
  return FieldViolationError(
      "filter", absl::StrCat("\"", condition, "\": ", problem, "; want ", kFilterSyntax));
}

}  // namespace

absl::Status ValidateDisplayNameAndLabels(
    const std::string& display_name,
    const google::protobuf::Map<std::string, std::string>& labels,
    absl::string_view prefix) {
  Violations violations;
  const std::string name_field = absl::StrCat(prefix, "display_name");
  // Characters, not bytes (protobuf has checked that it is UTF-8).
  size_t characters = 0;
  bool control = false;
  for (unsigned char c : display_name) {
    if ((c & 0xC0) != 0x80) ++characters;
    if (c < 0x20 || c == 0x7F) control = true;
  }
  if (characters > kMaxDisplayName) {
    violations.Add(FieldViolationError(
        name_field,
        absl::StrCat("at most ", kMaxDisplayName, " characters, got ", characters)));
  }
  if (control) {
    violations.Add(FieldViolationError(name_field, "must not hold control characters"));
  }
  if (labels.size() > kMaxLabels) {
    violations.Add(FieldViolationError(
        absl::StrCat(prefix, "labels"),
        absl::StrCat("at most ", kMaxLabels, " labels, got ", labels.size())));
  }
  // In key order, so that the message does not depend on the map's order.
  const Labels sorted(labels.begin(), labels.end());
  for (const auto& [key, value] : sorted) {
    const std::string field = absl::StrCat(prefix, "labels[\"", key, "\"]");
    if (!IsLabelKey(key)) {
      violations.Add(FieldViolationError(
          field,
          "a key is 1-63 characters of a-z, 0-9, _ and -, starting with a letter"));
    }
    if (!IsLabelText(value)) {
      violations.Add(FieldViolationError(
          field, absl::StrCat("a value is 0-63 characters of a-z, 0-9, _ and -, got \"",
                              value.substr(0, 80), "\"")));
    }
  }
  return violations.Result();
}

absl::StatusOr<LabelFilter> LabelFilter::Parse(absl::string_view filter) {
  LabelFilter parsed;
  if (absl::StripAsciiWhitespace(filter).empty()) return parsed;
  for (absl::string_view part : absl::StrSplit(filter, " AND ")) {
    const absl::string_view condition = absl::StripAsciiWhitespace(part);
    const std::string lower = absl::AsciiStrToLower(condition);
    if (absl::StrContains(lower, " and ") || absl::StrContains(lower, " or ")) {
      return FilterError(condition,
                         "join conditions with AND in capitals (OR is not supported)");
    }
    absl::string_view rest = condition;
    if (!absl::ConsumePrefix(&rest, "labels.")) {
      return FilterError(condition, "only labels can be filtered on");
    }
    Condition c;
    size_t key_end = 0;
    while (key_end < rest.size() && IsLabelChar(rest[key_end])) ++key_end;
    c.key = std::string(rest.substr(0, key_end));
    rest = absl::StripLeadingAsciiWhitespace(rest.substr(key_end));
    if (!IsLabelKey(c.key)) return FilterError(condition, "not a label key");
    if (absl::ConsumePrefix(&rest, ":")) {
      if (absl::StripAsciiWhitespace(rest) != "*") {
        return FilterError(condition, "only labels.KEY:* (has the key) is supported");
      }
      c.op = Op::kHas;
    } else if (absl::ConsumePrefix(&rest, "!=")) {
      c.op = Op::kNotEquals;
    } else if (absl::ConsumePrefix(&rest, "=")) {
      c.op = Op::kEquals;
    } else {
      return FilterError(condition, "expected =, != or :* after the key");
    }
    if (c.op != Op::kHas) {
      absl::string_view value = absl::StripAsciiWhitespace(rest);
      if (value.size() >= 2 && value.front() == '"' && value.back() == '"') {
        value = value.substr(1, value.size() - 2);
      }
      if (!IsLabelText(value)) {
        return FilterError(condition, "a value is 0-63 characters of a-z, 0-9, _ and -");
      }
      c.value = std::string(value);
    }
    parsed.conditions_.push_back(std::move(c));
  }
  return parsed;
}

bool LabelFilter::Matches(const Labels& labels) const {
  for (const Condition& c : conditions_) {
    const auto it = labels.find(c.key);
    const bool has = it != labels.end();
    switch (c.op) {
      case Op::kHas:
        if (!has) return false;
        break;
      case Op::kEquals:
        if (!has || it->second != c.value) return false;
        break;
      case Op::kNotEquals:
        if (has && it->second == c.value) return false;
        break;
    }
  }
  return true;
}

}  // namespace excite::service
