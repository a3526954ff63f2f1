#ifndef EXCITE_SIM_SIM_CONFIG_H_
#define EXCITE_SIM_SIM_CONFIG_H_

#include <cstdint>
#include <optional>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "excite/v1/sim_config.pb.h"
#include "sim/evaluation.h"

namespace excite::sim {

// Reads a SimConfig from a protobuf text-format file. NOT_FOUND if the file cannot
// be read, INVALID_ARGUMENT (with protobuf's line:column message) if it does not
// parse. Does not validate: call ValidateSimConfig.
absl::StatusOr<v1::SimConfig> LoadSimConfig(const std::string& path);

// Parses a SimConfig from text format (same errors as LoadSimConfig).
absl::StatusOr<v1::SimConfig> ParseSimConfig(absl::string_view text);

// The checks excite-sim needs before it starts (INVALID_ARGUMENT naming the field):
// session passes the server's ValidateSessionConfig (server/service/
// config_validation.h, fields named "session.<field>"); and, on top of it, a plant the
// factory accepts whose dims equal session.state_dim/input_dim; session.input_bounds and
// session.state_bounds (the region of interest, required here) with one finite lower <
// upper interval per dimension; noise.variance > 0; horizon >= 1; samples >= 1;
// evaluation points, every_samples, marginal_bins and joint_bins >= 1.
absl::Status ValidateSimConfig(const v1::SimConfig& config);

// Command-line overrides of a config (unset members leave it unchanged).
struct SimOverrides {
  std::optional<v1::Strategy> strategy;
  std::optional<int> samples;
  // Session seed (server-side randomness) and measurement-noise seed.
  std::optional<uint64_t> seed;
};
void ApplyOverrides(const SimOverrides& overrides, v1::SimConfig* config);

// A config's bounds (state_bounds, input_bounds) as a Box.
Box BoxOf(const google::protobuf::RepeatedPtrField<v1::Interval>& bounds);

}  // namespace excite::sim

#endif  // EXCITE_SIM_SIM_CONFIG_H_
