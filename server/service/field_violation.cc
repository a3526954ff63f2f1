#include "server/service/field_violation.h"

#include <algorithm>
#include <cstddef>

#include "absl/strings/cord.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"

namespace excite::service {
namespace {

// Payload type URL; the payload is the field path as plain bytes.
constexpr absl::string_view kFieldPayload = "type.excite.dev/excite.FieldPath";
// Several violations: "field\x1fdescription" records separated by "\x1e" (ASCII
// unit and record separators, which no field path or message contains).
constexpr absl::string_view kViolationsPayload = "type.excite.dev/excite.FieldViolations";

// The description of a FieldViolationError: its message after "<field>: ".
std::string DescriptionOf(const absl::Status& status, absl::string_view field) {
  const std::string message(status.message());
  const std::string prefix = absl::StrCat(field, ": ");
  const size_t at = message.find(prefix);
  return at == std::string::npos ? message : message.substr(at + prefix.size());
}

}  // namespace

absl::Status FieldViolationError(absl::string_view field, absl::string_view description) {
  absl::Status status =
      absl::InvalidArgumentError(absl::StrCat(field, ": ", description));
  status.SetPayload(kFieldPayload, absl::Cord(field));
  return status;
}

std::optional<std::string> ViolatedField(const absl::Status& status) {
  const auto payload = status.GetPayload(kFieldPayload);  // absl::optional
  if (!payload.has_value()) return std::nullopt;
  return std::string(*payload);
}

absl::Status WithMessage(const absl::Status& status, absl::string_view message) {
  if (status.ok()) return status;
  absl::Status result(status.code(), message);
  status.ForEachPayload([&result](absl::string_view type_url, const absl::Cord& payload) {
    result.SetPayload(type_url, payload);
  });
  return result;
}

std::vector<FieldViolation> FieldViolations(const absl::Status& status) {
  std::vector<FieldViolation> result;
  if (const auto many = status.GetPayload(kViolationsPayload); many.has_value()) {
    for (absl::string_view record : absl::StrSplit(std::string(*many), '\x1e')) {
      const std::vector<std::string> parts =
          absl::StrSplit(record, absl::MaxSplits('\x1f', 1));
      if (parts.size() == 2) result.push_back({parts[0], parts[1]});
    }
    return result;
  }
  if (std::optional<std::string> field = ViolatedField(status)) {
    result.push_back({*field, DescriptionOf(status, *field)});
  }
  return result;
}

void Violations::Add(absl::Status status) {
  if (!status.ok()) errors_.push_back(std::move(status));
}

absl::Status Violations::Result() const {
  if (errors_.empty()) return absl::OkStatus();
  if (errors_.size() == 1) return errors_.front();
  std::vector<std::string> messages;
  std::vector<std::string> records;
  for (const absl::Status& error : errors_) {
    const std::vector<FieldViolation> violations = FieldViolations(error);
    // A Result() added here is flattened: one entry per problem.
    if (violations.size() > 1) {
      for (const FieldViolation& v : violations) {
        messages.push_back(absl::StrCat(v.field, ": ", v.description));
      }
    } else {
      messages.emplace_back(error.message());
    }
    for (const FieldViolation& v : violations) {
      records.push_back(absl::StrCat(v.field, "\x1f", v.description));
    }
  }
  std::string listed = absl::StrJoin(
      messages.begin(),
      messages.begin() +
          static_cast<std::ptrdiff_t>(std::min(messages.size(), kMaxListedProblems)),
      "; ");
  if (messages.size() > kMaxListedProblems) {
    absl::StrAppend(&listed, "; ... and ", messages.size() - kMaxListedProblems, " more");
  }
  absl::Status result =
      absl::InvalidArgumentError(absl::StrCat(messages.size(), " problems: ", listed));
  result.SetPayload(kViolationsPayload, absl::Cord(absl::StrJoin(records, "\x1e")));
  return result;
}

}  // namespace excite::service
