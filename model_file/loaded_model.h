#ifndef EXCITE_MODEL_FILE_LOADED_MODEL_H_
#define EXCITE_MODEL_FILE_LOADED_MODEL_H_

#include <string>

#include "Eigen/Core"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "model_file/model_data.h"

namespace excite {

// A learned dynamics model read from a model file (ExportModel, `excite
// export-model`), predicting without a server: a controller links this
// (library excite_model: Eigen and Abseil's Status, no gRPC, no protobuf).
// Thread-safe (const after loading).
class LoadedModel {
 public:
  // The file at `path`: NOT_FOUND if it cannot be opened; otherwise as FromBytes.
  static absl::StatusOr<LoadedModel> Load(const std::string& path);
  // INVALID_ARGUMENT for bytes that are not a model file, FAILED_PRECONDITION
  // for a newer format version (model::DecodeModelFile).
  static absl::StatusOr<LoadedModel> FromBytes(absl::string_view bytes);

  int state_dim() const { return data_.state_dim; }
  int input_dim() const { return data_.input_dim; }
  const model::ModelData& data() const { return data_; }

  // For points z (m x (state_dim + input_dim), one (x, u) per row): the mean of
  // the next state and its variance (m x state_dim each; either may be null), as
  // the server's Predict: the latent variance, or with `include_noise` that of a
  // measured next state. INVALID_ARGUMENT if z has the wrong number of columns.
  absl::Status Predict(const Eigen::MatrixXd& z, Eigen::MatrixXd* mean,
                       Eigen::MatrixXd* variance, bool include_noise = false) const;

 private:
  explicit LoadedModel(model::ModelData data) : data_(std::move(data)) {}
  model::ModelData data_;
};

}  // namespace excite

#endif  // EXCITE_MODEL_FILE_LOADED_MODEL_H_
