#include "server/service/config_text.h"

#include <fstream>
#include <sstream>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "excite/v1/sim_config.pb.h"
#include "google/protobuf/io/tokenizer.h"
#include "google/protobuf/text_format.h"

namespace excite::service {
namespace {

class CollectErrors : public google::protobuf::io::ErrorCollector {
 public:
  void AddError(int line, google::protobuf::io::ColumnNumber column,
                const std::string& message) override {
    errors_.push_back(absl::StrCat(line + 1, ":", column + 1, ": ", message));
  }
  void AddWarning(int /*line*/, google::protobuf::io::ColumnNumber /*column*/,
                  const std::string& /*message*/) override {}
  std::string Joined() const { return absl::StrJoin(errors_, "; "); }

 private:
  std::vector<std::string> errors_;
};

}  // namespace

absl::StatusOr<v1::SessionConfig> ParseSessionConfigText(absl::string_view text) {
  v1::SessionConfig config;
  CollectErrors errors;
  google::protobuf::TextFormat::Parser parser;
  parser.RecordErrorsTo(&errors);
  if (!parser.ParseFromString(std::string(text), &config)) {
    return absl::InvalidArgumentError(
        absl::StrCat("SessionConfig text format: ", errors.Joined()));
  }
  return config;
}

absl::StatusOr<v1::SessionConfig> LoadSessionConfigFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) return absl::NotFoundError(absl::StrCat("cannot read ", path));
  std::stringstream buffer;
  buffer << in.rdbuf();
  absl::StatusOr<v1::SessionConfig> config = ParseSessionConfigText(buffer.str());
  if (config.ok()) return config;
  // The plants' files (sim/configs) hold their session's config as `session`.
  v1::SimConfig sim;
  CollectErrors sim_errors;
  google::protobuf::TextFormat::Parser parser;
  parser.RecordErrorsTo(&sim_errors);
  if (parser.ParseFromString(buffer.str(), &sim)) return sim.session();
  return absl::InvalidArgumentError(absl::StrCat(
      path, ": neither a SessionConfig nor a SimConfig: ", config.status().message(),
      "; SimConfig text format: ", sim_errors.Joined()));
}

}  // namespace excite::service
