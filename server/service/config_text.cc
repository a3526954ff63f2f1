#include "server/service/config_text.h"

#include <fstream>
#include <map>
#include <sstream>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "excite/v1/sim_config.pb.h"
#include "google/protobuf/io/tokenizer.h"
#include "google/protobuf/io/zero_copy_stream_impl_lite.h"
#include "google/protobuf/text_format.h"

namespace excite::service {
namespace {

using google::protobuf::Descriptor;
using google::protobuf::EnumDescriptor;
using google::protobuf::EnumValueDescriptor;
using google::protobuf::io::Tokenizer;

// Enum fields anywhere under `root`, by field name (a name that two enums share
// is left out: it could not be told apart without the message context).
std::map<std::string, const EnumDescriptor*> EnumFields(const Descriptor* root) {
  std::map<std::string, const EnumDescriptor*> fields;
  std::vector<std::string> ambiguous;
  std::vector<const Descriptor*> todo = {root};
  for (size_t k = 0; k < todo.size() && k < 64; ++k) {
    for (int i = 0; i < todo[k]->field_count(); ++i) {
      const google::protobuf::FieldDescriptor* f = todo[k]->field(i);
      if (f->message_type() != nullptr) todo.push_back(f->message_type());
      if (f->enum_type() == nullptr) continue;
      auto [it, added] = fields.emplace(f->name(), f->enum_type());
      if (!added && it->second != f->enum_type()) ambiguous.push_back(f->name());
    }
  }
  for (const std::string& name : ambiguous) fields.erase(name);
  return fields;
}

// "STRATEGY_" for Strategy: what every value name of `e` starts with, up to
// its last '_' ("" if nothing is shared).
std::string EnumPrefix(const EnumDescriptor* e) {
  std::string prefix = e->value(0)->name();
  for (int v = 1; v < e->value_count(); ++v) {
    const std::string& name = e->value(v)->name();
    size_t n = 0;
    while (n < prefix.size() && n < name.size() && prefix[n] == name[n]) ++n;
    prefix.resize(n);
  }
  const size_t underscore = prefix.rfind('_');
  return underscore == std::string::npos ? "" : prefix.substr(0, underscore + 1);
}

// The value `name` means: the value's name, or its short name ("rec" for
// STRATEGY_REC), in any case; null if none.
const EnumValueDescriptor* FindEnumValue(const EnumDescriptor* e,
                                         absl::string_view name) {
  const std::string upper = absl::AsciiStrToUpper(name);
  if (const EnumValueDescriptor* v = e->FindValueByName(upper)) return v;
  return e->FindValueByName(EnumPrefix(e) + upper);
}

// " Valid: rec, pa, ... (any case, or the enum names STRATEGY_REC, ...)." for
// an enum field named `field` somewhere under `root` (protobuf's "Unknown
// enumeration value" error does not list them); "" if none.
std::string ValidEnumValues(const Descriptor* root, absl::string_view field) {
  const std::map<std::string, const EnumDescriptor*> fields = EnumFields(root);
  const auto it = fields.find(std::string(field));
  if (it == fields.end()) return "";
  const EnumDescriptor* e = it->second;
  const std::string prefix = EnumPrefix(e);
  std::vector<std::string> names;
  for (int v = 0; v < e->value_count(); ++v) {
    if (e->value(v)->number() != 0) {
      names.push_back(absl::AsciiStrToLower(e->value(v)->name().substr(prefix.size())));
    }
  }
  return absl::StrCat(" Valid: ", absl::StrJoin(names, ", "),
                      " (any case, with or without ", prefix, ").");
}

class IgnoreErrors : public google::protobuf::io::ErrorCollector {
 public:
  void AddError(int, google::protobuf::io::ColumnNumber, const std::string&) override {}
};

// Byte offset of the tokenizer's (line, column): it counts a tab as up to the
// next multiple of 8 columns.
size_t Offset(const std::vector<size_t>& line_starts, absl::string_view text, int line,
              int column) {
  size_t at = line_starts[static_cast<size_t>(line)];
  for (int c = 0; c < column && at < text.size() && text[at] != '\n'; ++at) {
    c = text[at] == '\t' ? (c / 8 + 1) * 8 : c + 1;
  }
  return at;
}

// `text` with every enum value written by its short name or in another case
// ("strategy: rec", "members: [Roi, STRATEGY_random]") replaced by the enum's
// name, which is all protobuf's text parser takes. Anything else is left to
// the parser, and its errors.
std::string WithEnumNames(absl::string_view text, const Descriptor* root) {
  const std::map<std::string, const EnumDescriptor*> fields = EnumFields(root);
  google::protobuf::io::ArrayInputStream input(text.data(),
                                               static_cast<int>(text.size()));
  IgnoreErrors errors;
  Tokenizer tokenizer(&input, &errors);
  tokenizer.set_comment_style(Tokenizer::SH_COMMENT_STYLE);
  struct Edit {
    int line;
    int column;
    size_t length;
    std::string name;
  };
  std::vector<Edit> edits;
  const EnumDescriptor* field = nullptr;  // the enum whose value(s) come next
  enum class Expect { kField, kColon, kValue, kListValue } expect = Expect::kField;
  while (tokenizer.Next()) {
    const Tokenizer::Token& t = tokenizer.current();
    const bool identifier = t.type == Tokenizer::TYPE_IDENTIFIER;
    if ((expect == Expect::kValue || expect == Expect::kListValue) && identifier) {
      const EnumValueDescriptor* v = field->FindValueByName(t.text) != nullptr
                                         ? nullptr
                                         : FindEnumValue(field, t.text);
      if (v != nullptr) edits.push_back({t.line, t.column, t.text.size(), v->name()});
      if (expect == Expect::kValue) expect = Expect::kField;
      continue;
    }
    if (expect == Expect::kColon && t.text == ":") {
      expect = Expect::kValue;
    } else if (expect == Expect::kValue && t.text == "[") {
      expect = Expect::kListValue;
    } else if (expect == Expect::kListValue && t.text == ",") {
      // the next value
    } else if (identifier && fields.count(t.text) > 0) {
      field = fields.at(t.text);
      expect = Expect::kColon;
    } else {
      expect = Expect::kField;
    }
  }
  if (edits.empty()) return std::string(text);
  std::vector<size_t> line_starts = {0};
  for (size_t i = 0; i < text.size(); ++i) {
    if (text[i] == '\n') line_starts.push_back(i + 1);
  }
  std::string out(text);
  for (auto e = edits.rbegin(); e != edits.rend(); ++e) {
    out.replace(Offset(line_starts, text, e->line, e->column), e->length, e->name);
  }
  return out;
}

class CollectErrors : public google::protobuf::io::ErrorCollector {
 public:
  explicit CollectErrors(const Descriptor* root) : root_(root) {}
  void AddError(int line, google::protobuf::io::ColumnNumber column,
                const std::string& message) override {
    std::string hint;
    // Unknown enumeration value of "X" for field "F".
    const size_t at = message.find("for field \"");
    if (absl::StartsWith(message, "Unknown enumeration value") &&
        at != std::string::npos) {
      const size_t begin = at + 11;
      const size_t end = message.find('"', begin);
      if (end != std::string::npos) {
        hint = ValidEnumValues(root_, message.substr(begin, end - begin));
      }
    }
    errors_.push_back(absl::StrCat(line + 1, ":", column + 1, ": ", message, hint));
  }
  void AddWarning(int /*line*/, google::protobuf::io::ColumnNumber /*column*/,
                  const std::string& /*message*/) override {}
  std::string Joined() const { return absl::StrJoin(errors_, "; "); }

 private:
  const Descriptor* const root_;
  std::vector<std::string> errors_;
};

}  // namespace

absl::Status ParseTextProto(absl::string_view text, google::protobuf::Message* message) {
  CollectErrors errors(message->GetDescriptor());
  google::protobuf::TextFormat::Parser parser;
  parser.RecordErrorsTo(&errors);
  if (!parser.ParseFromString(WithEnumNames(text, message->GetDescriptor()), message)) {
    return absl::InvalidArgumentError(errors.Joined());
  }
  return absl::OkStatus();
}

absl::StatusOr<std::string> ReadTextFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) return absl::NotFoundError(absl::StrCat("cannot read ", path));
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

absl::StatusOr<v1::SessionConfig> ParseSessionConfigText(absl::string_view text) {
  v1::SessionConfig config;
  if (absl::Status s = ParseTextProto(text, &config); !s.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat("SessionConfig text format: ", s.message()));
  }
  return config;
}

absl::StatusOr<v1::SessionConfig> LoadSessionConfigFile(const std::string& path) {
  absl::StatusOr<std::string> text = ReadTextFile(path);
  if (!text.ok()) return text.status();
  absl::StatusOr<v1::SessionConfig> config = ParseSessionConfigText(*text);
  if (config.ok()) return config;
  // The plants' files (sim/configs) hold their session's config as `session`.
  v1::SimConfig sim;
  const absl::Status sim_parsed = ParseTextProto(*text, &sim);
  if (sim_parsed.ok()) return sim.session();
  // Say only the reading that got past the first field name.
  const bool session_fields =
      !absl::StrContains(config.status().message(), "SessionConfig\" has no field named");
  const bool sim_fields =
      !absl::StrContains(sim_parsed.message(), "SimConfig\" has no field named");
  if (session_fields && !sim_fields) {
    return absl::Status(config.status().code(),
                        absl::StrCat(path, ": ", config.status().message()));
  }
  if (sim_fields && !session_fields) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": SimConfig text format: ", sim_parsed.message()));
  }
  return absl::InvalidArgumentError(absl::StrCat(
      path, ": neither a SessionConfig nor a SimConfig: ", config.status().message(),
      "; SimConfig text format: ", sim_parsed.message()));
}

}  // namespace excite::service
