#ifndef EXCITE_MODEL_FILE_MODEL_FILE_H_
#define EXCITE_MODEL_FILE_MODEL_FILE_H_

#include <string>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "model_file/model_data.h"

namespace excite::model {

// The newest model file format version this code writes and reads; a reader
// refuses a newer one. docs/model-file.md documents the layout. Version 2 adds
// prior_slopes (a linear prior mean); a model whose slopes are all 0 is written
// as version 1, which readers of version 1 still read.
inline constexpr uint32_t kModelFileVersion = 2;

// The version EncodeModelFile writes for `model`: the oldest that holds it.
uint32_t ModelFileVersion(const ModelData& model);

// The file's bytes: "EXCITEMF", the version (uint32), the number of arrays
// (uint32), then each array as its name (uint32 length + bytes), its rows and
// columns (uint64 each) and rows * cols float64 in row-major order; every
// integer and double little-endian.
std::string EncodeModelFile(const ModelData& model);

// INVALID_ARGUMENT for bytes that are not a model file (naming what is wrong),
// FAILED_PRECONDITION for a newer format version, with the version in the
// message; the arrays' shapes are checked against each other.
absl::StatusOr<ModelData> DecodeModelFile(absl::string_view bytes);

}  // namespace excite::model

#endif  // EXCITE_MODEL_FILE_MODEL_FILE_H_
