#ifndef EXCITE_SIM_PLANTS_MODELS_EMBEDDED_MODELS_H_
#define EXCITE_SIM_PLANTS_MODELS_EMBEDDED_MODELS_H_

#include "absl/strings/string_view.h"

namespace excite::sim {

// The MJCF text of a model compiled into the binary from sim/plants/models/<name>.xml
// (sim/CMakeLists.txt generates the definition at configure time), so binaries do not
// depend on the source tree. Names: "dipc", "half_cheetah". Empty if unknown.
absl::string_view EmbeddedMjcf(absl::string_view name);

}  // namespace excite::sim

#endif  // EXCITE_SIM_PLANTS_MODELS_EMBEDDED_MODELS_H_
