#include "model_file/model_file.h"

#include <cstring>
#include <map>
#include <tuple>
#include <utility>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"

namespace excite::model {
namespace {

constexpr char kMagic[] = "EXCITEMF";  // 8 bytes, no terminator written
constexpr size_t kMagicSize = 8;
using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// Little-endian integers whatever the host (doubles: IEEE 754 in the host's
// byte order, which is little-endian on every platform excite builds for).
template <typename T>
void PutInteger(T value, std::string* out) {
  for (size_t i = 0; i < sizeof(T); ++i) {
    out->push_back(static_cast<char>((value >> (8 * i)) & 0xff));
  }
}

void PutArray(const std::string& name, const Eigen::MatrixXd& values, std::string* out) {
  PutInteger(static_cast<uint32_t>(name.size()), out);
  out->append(name);
  PutInteger(static_cast<uint64_t>(values.rows()), out);
  PutInteger(static_cast<uint64_t>(values.cols()), out);
  const RowMajor row_major = values;
  out->append(reinterpret_cast<const char*>(row_major.data()),
              sizeof(double) * static_cast<size_t>(row_major.size()));
}

Eigen::MatrixXd Row(const Eigen::VectorXd& v) { return v.transpose(); }
Eigen::MatrixXd Scalar(double v) { return Eigen::MatrixXd::Constant(1, 1, v); }

class Reader {
 public:
  explicit Reader(absl::string_view bytes) : bytes_(bytes) {}
  template <typename T>
  bool Integer(T* value) {
    if (bytes_.size() - at_ < sizeof(T)) return false;
    *value = 0;
    for (size_t i = 0; i < sizeof(T); ++i) {
      *value |= static_cast<T>(static_cast<unsigned char>(bytes_[at_ + i])) << (8 * i);
    }
    at_ += sizeof(T);
    return true;
  }
  bool Bytes(size_t count, absl::string_view* out) {
    if (bytes_.size() - at_ < count) return false;
    *out = bytes_.substr(at_, count);
    at_ += count;
    return true;
  }
  bool done() const { return at_ == bytes_.size(); }

 private:
  absl::string_view bytes_;
  size_t at_ = 0;
};

absl::Status NotAModelFile(absl::string_view why) {
  return absl::InvalidArgumentError(absl::StrCat("not an excite model file: ", why));
}

// The arrays by name, with their shapes checked as they are taken.
class Arrays {
 public:
  std::map<std::string, Eigen::MatrixXd> by_name;

  absl::StatusOr<Eigen::MatrixXd> Take(const std::string& name, Eigen::Index rows,
                                       Eigen::Index cols) {
    auto it = by_name.find(name);
    if (it == by_name.end()) return NotAModelFile(absl::StrCat("no array ", name));
    if ((rows >= 0 && it->second.rows() != rows) ||
        (cols >= 0 && it->second.cols() != cols)) {
      return NotAModelFile(absl::StrCat(name, " is ", it->second.rows(), " x ",
                                        it->second.cols(), ", expected ", rows, " x ",
                                        cols, " (-1: any)"));
    }
    if (!it->second.allFinite())
      return NotAModelFile(absl::StrCat(name, " is not finite"));
    Eigen::MatrixXd out = std::move(it->second);
    by_name.erase(it);
    return out;
  }
};

std::string OutputName(size_t j, const char* what) {
  return absl::StrCat("output.", j, ".", what);
}

}  // namespace

uint32_t ModelFileVersion(const ModelData& model) {
  return model.prior_slopes.size() > 0 && !model.prior_slopes.isZero(0.0) ? 2 : 1;
}

std::string EncodeModelFile(const ModelData& model) {
  std::string out(kMagic, kMagicSize);
  const uint32_t version = ModelFileVersion(model);
  const bool slopes = version >= 2;
  PutInteger(version, &out);
  const size_t arrays = 7 + (slopes ? 1 : 0) + 6 * model.outputs.size();
  PutInteger(static_cast<uint32_t>(arrays), &out);
  Eigen::MatrixXd dims(1, 5);
  dims << model.state_dim, model.input_dim, model.delta ? 1.0 : 0.0,
      static_cast<double>(model.sample_count), static_cast<double>(model.model_version);
  PutArray("dims", dims, &out);
  Eigen::MatrixXd angles(1, static_cast<Eigen::Index>(model.angle_dims.size()));
  for (size_t i = 0; i < model.angle_dims.size(); ++i) {
    angles(0, static_cast<Eigen::Index>(i)) = model.angle_dims[i];
  }
  PutArray("angle_dims", angles, &out);
  PutArray("feature_center", Row(model.feature_center), &out);
  PutArray("feature_half_width", Row(model.feature_half_width), &out);
  PutArray("prior_mean", Row(model.prior_mean), &out);
  if (slopes) PutArray("prior_slopes", model.prior_slopes, &out);
  PutArray("output_std", Row(model.output_std), &out);
  PutArray("noise_variance", Row(model.noise_variance), &out);
  for (size_t j = 0; j < model.outputs.size(); ++j) {
    const OutputData& o = model.outputs[j];
    PutArray(OutputName(j, "signal_variance"), Scalar(o.signal_variance), &out);
    PutArray(OutputName(j, "lengthscales"), Row(o.lengthscales), &out);
    PutArray(OutputName(j, "points"), o.points, &out);
    PutArray(OutputName(j, "weights"), Row(o.weights), &out);
    PutArray(OutputName(j, "factor"), o.factor, &out);
    PutArray(OutputName(j, "sparse_factor"), o.sparse_factor, &out);
  }
  return out;
}

absl::StatusOr<ModelData> DecodeModelFile(absl::string_view bytes) {
  Reader reader(bytes);
  absl::string_view magic;
  if (!reader.Bytes(kMagicSize, &magic) ||
      magic != absl::string_view(kMagic, kMagicSize)) {
    return NotAModelFile("it does not start with EXCITEMF");
  }
  uint32_t version = 0;
  uint32_t count = 0;
  if (!reader.Integer(&version) || !reader.Integer(&count)) {
    return NotAModelFile("the header is cut short");
  }
  if (version > kModelFileVersion) {
    return absl::FailedPreconditionError(
        absl::StrCat("the model file has format version ", version,
                     "; this reader knows versions up "
                     "to ",
                     kModelFileVersion, ": read it with a newer excite"));
  }
  if (version == 0) return NotAModelFile("format version 0");
  Arrays arrays;
  for (uint32_t a = 0; a < count; ++a) {
    uint32_t name_size = 0;
    absl::string_view name;
    uint64_t rows = 0;
    uint64_t cols = 0;
    if (!reader.Integer(&name_size) || !reader.Bytes(name_size, &name) ||
        !reader.Integer(&rows) || !reader.Integer(&cols)) {
      return NotAModelFile(absl::StrCat("array ", a, " of ", count, " is cut short"));
    }
    // Bounds before multiplying: no overflow, no allocation beyond the bytes.
    absl::string_view data;
    if (rows > bytes.size() || cols > bytes.size() ||
        (rows > 0 && cols > bytes.size() / sizeof(double) / rows) ||
        !reader.Bytes(sizeof(double) * rows * cols, &data)) {
      return NotAModelFile(
          absl::StrCat("array ", name, " (", rows, " x ", cols, ") runs past the end"));
    }
    RowMajor values(static_cast<Eigen::Index>(rows), static_cast<Eigen::Index>(cols));
    if (!data.empty()) std::memcpy(values.data(), data.data(), data.size());
    arrays.by_name[std::string(name)] = values;
  }
  if (!reader.done()) return NotAModelFile("bytes follow the last array");

  ModelData model;
  absl::StatusOr<Eigen::MatrixXd> dims = arrays.Take("dims", 1, 5);
  if (!dims.ok()) return dims.status();
  model.state_dim = static_cast<int>((*dims)(0, 0));
  model.input_dim = static_cast<int>((*dims)(0, 1));
  model.delta = (*dims)(0, 2) != 0.0;
  model.sample_count = static_cast<int64_t>((*dims)(0, 3));
  model.model_version = static_cast<int64_t>((*dims)(0, 4));
  if (model.state_dim < 1 || model.input_dim < 0 || model.state_dim > 1000000 ||
      model.input_dim > 1000000) {
    return NotAModelFile("impossible dimensions");
  }
  absl::StatusOr<Eigen::MatrixXd> angles = arrays.Take("angle_dims", 1, -1);
  if (!angles.ok()) return angles.status();
  for (Eigen::Index i = 0; i < angles->cols(); ++i) {
    const double a = (*angles)(0, i);
    if (a < 0 || a >= model.state_dim || a != static_cast<int>(a)) {
      return NotAModelFile(absl::StrCat("angle_dims holds ", a));
    }
    model.angle_dims.push_back(static_cast<int>(a));
  }
  const Eigen::Index features = model.state_dim + model.input_dim +
                                static_cast<Eigen::Index>(model.angle_dims.size());
  const auto vector = [&arrays](const std::string& name, Eigen::Index size,
                                Eigen::VectorXd* out) -> absl::Status {
    absl::StatusOr<Eigen::MatrixXd> row = arrays.Take(name, 1, size);
    if (!row.ok()) return row.status();
    *out = row->transpose();
    return absl::OkStatus();
  };
  for (const auto& [name, size, out] :
       {std::make_tuple("feature_center", features, &model.feature_center),
        std::make_tuple("feature_half_width", features, &model.feature_half_width),
        std::make_tuple("prior_mean", Eigen::Index{model.state_dim}, &model.prior_mean),
        std::make_tuple("output_std", Eigen::Index{model.state_dim}, &model.output_std),
        std::make_tuple("noise_variance", Eigen::Index{model.state_dim},
                        &model.noise_variance)}) {
    if (absl::Status s = vector(name, size, out); !s.ok()) return s;
  }
  model.prior_slopes = Eigen::MatrixXd::Zero(model.state_dim, features);
  if (version >= 2) {
    absl::StatusOr<Eigen::MatrixXd> slopes =
        arrays.Take("prior_slopes", model.state_dim, features);
    if (!slopes.ok()) return slopes.status();
    model.prior_slopes = *std::move(slopes);
  }
  for (int j = 0; j < model.state_dim; ++j) {
    OutputData o;
    absl::StatusOr<Eigen::MatrixXd> sf2 =
        arrays.Take(OutputName(j, "signal_variance"), 1, 1);
    if (!sf2.ok()) return sf2.status();
    o.signal_variance = (*sf2)(0, 0);
    if (absl::Status s = vector(OutputName(j, "lengthscales"), features, &o.lengthscales);
        !s.ok()) {
      return s;
    }
    absl::StatusOr<Eigen::MatrixXd> points =
        arrays.Take(OutputName(j, "points"), -1, features);
    if (!points.ok()) return points.status();
    o.points = *std::move(points);
    const Eigen::Index m = o.points.rows();
    if (absl::Status s = vector(OutputName(j, "weights"), m, &o.weights); !s.ok())
      return s;
    absl::StatusOr<Eigen::MatrixXd> factor = arrays.Take(OutputName(j, "factor"), m, m);
    if (!factor.ok()) return factor.status();
    o.factor = *std::move(factor);
    absl::StatusOr<Eigen::MatrixXd> sparse =
        arrays.Take(OutputName(j, "sparse_factor"), -1, -1);
    if (!sparse.ok()) return sparse.status();
    if (sparse->size() != 0 && (sparse->rows() != m || sparse->cols() != m)) {
      return NotAModelFile(
          absl::StrCat(OutputName(j, "sparse_factor"), " is not ", m, " x ", m));
    }
    o.sparse_factor = *std::move(sparse);
    if (!(o.signal_variance > 0) || !(o.lengthscales.array() > 0).all() ||
        (o.factor.diagonal().array() <= 0).any()) {
      return NotAModelFile(absl::StrCat("output ", j,
                                        " has a non-positive hyperparameter "
                                        "or factor pivot"));
    }
    model.outputs.push_back(std::move(o));
  }
  if (!(model.feature_half_width.array() > 0).all() ||
      !(model.output_std.array() > 0).all()) {
    return NotAModelFile("a half-width or an output std is not positive");
  }
  return model;
}

}  // namespace excite::model
