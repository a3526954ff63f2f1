#include "server/service/config_text.h"

#include <fstream>
#include <sstream>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "excite/v1/sim_config.pb.h"
#include "google/protobuf/io/tokenizer.h"
#include "google/protobuf/text_format.h"

namespace excite::service {
namespace {

// "; valid: A, B, ..." for an enum field named `field` somewhere under `root`
// (protobuf's "Unknown enumeration value" error does not list them); "" if none.
std::string ValidEnumValues(const google::protobuf::Descriptor* root,
                            absl::string_view field) {
  std::vector<const google::protobuf::Descriptor*> todo = {root};
  for (size_t k = 0; k < todo.size() && k < 64; ++k) {
    for (int i = 0; i < todo[k]->field_count(); ++i) {
      const google::protobuf::FieldDescriptor* f = todo[k]->field(i);
      if (f->message_type() != nullptr) todo.push_back(f->message_type());
      if (f->name() != field || f->enum_type() == nullptr) continue;
      std::vector<std::string> names;
      for (int v = 0; v < f->enum_type()->value_count(); ++v) {
        if (f->enum_type()->value(v)->number() != 0) {
          names.push_back(f->enum_type()->value(v)->name());
        }
      }
      return absl::StrCat(" Valid: ", absl::StrJoin(names, ", "), ".");
    }
  }
  return "";
}

class CollectErrors : public google::protobuf::io::ErrorCollector {
 public:
  explicit CollectErrors(const google::protobuf::Descriptor* root) : root_(root) {}
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
  const google::protobuf::Descriptor* const root_;
  std::vector<std::string> errors_;
};

}  // namespace

absl::Status ParseTextProto(absl::string_view text, google::protobuf::Message* message) {
  CollectErrors errors(message->GetDescriptor());
  google::protobuf::TextFormat::Parser parser;
  parser.RecordErrorsTo(&errors);
  if (!parser.ParseFromString(std::string(text), message)) {
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
