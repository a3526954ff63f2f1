"""A learned model taken home: predict from a model file without a server.

    model = excite.Model.load("pendulum.model")      # from Session.export_model()
    p = model.predict(z)                            # z: (n, state_dim + input_dim)
    p.mean, p.variance                              # (n, state_dim) each

This module needs numpy only (no gRPC, no protobuf): copy it next to a
controller if excite is not installed there. The format is docs/model-file.md.
"""

import dataclasses
import os
import struct
from typing import Dict, List, Tuple, Union

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]

#: The newest format version this reader knows; a newer file is refused. Version 2
#: adds prior_slopes (a linear prior mean).
FORMAT_VERSION = 2
_MAGIC = b"EXCITEMF"
_CHUNK = 256  # query points per pass


class ModelFileError(ValueError):
    """The bytes are not a model file this reader can use (a newer format included)."""


@dataclasses.dataclass(frozen=True)
class ModelPrediction:
    """Mean and variance of the next state, one row per point."""

    mean: FloatArray  # (n, state_dim)
    variance: FloatArray  # (n, state_dim)


@dataclasses.dataclass(frozen=True)
class _Output:
    signal_variance: float
    lengthscales: FloatArray
    points: FloatArray
    weights: FloatArray
    factor: FloatArray
    sparse_factor: FloatArray  # (0, 0) for an exact GP


def _arrays(data: bytes) -> Tuple[int, Dict[str, FloatArray]]:
    if data[:8] != _MAGIC:
        raise ModelFileError("not an excite model file: it does not start with EXCITEMF")
    if len(data) < 16:
        raise ModelFileError("not an excite model file: the header is cut short")
    version, count = struct.unpack_from("<II", data, 8)
    if version == 0:
        raise ModelFileError("not an excite model file: format version 0")
    if version > FORMAT_VERSION:
        raise ModelFileError(f"the model file has format version {version}; this reader "
                             f"knows versions up to {FORMAT_VERSION}: use a newer excite")
    at = 16
    arrays: Dict[str, FloatArray] = {}
    try:
        for _ in range(count):
            (name_size,) = struct.unpack_from("<I", data, at)
            name = data[at + 4:at + 4 + name_size].decode("ascii")
            at += 4 + name_size
            rows, cols = struct.unpack_from("<QQ", data, at)
            at += 16
            size = 8 * rows * cols
            if at + size > len(data):
                raise ModelFileError(f"not an excite model file: array {name} runs past "
                                     "the end")
            arrays[name] = np.frombuffer(data, dtype="<f8", count=rows * cols,
                                         offset=at).reshape(rows, cols).astype(np.float64)
            at += size
    except struct.error as error:
        raise ModelFileError(f"not an excite model file: cut short ({error})") from None
    if at != len(data):
        raise ModelFileError("not an excite model file: bytes follow the last array")
    return version, arrays


class Model:
    """A dynamics model read from a model file; see the module's docstring."""

    def __init__(self, data: bytes):
        version, arrays = _arrays(data)

        def take(name: str) -> FloatArray:
            if name not in arrays:
                raise ModelFileError(f"not an excite model file: no array {name}")
            return arrays[name]

        #: The file's format version (1, or 2 with a linear prior mean).
        self.format_version = version
        dims = take("dims").ravel()
        self.state_dim = int(dims[0])
        self.input_dim = int(dims[1])
        self.delta = bool(dims[2])
        self.sample_count = int(dims[3])
        self.model_version = int(dims[4])
        self.angle_dims: List[int] = [int(a) for a in take("angle_dims").ravel()]
        self._center = take("feature_center").ravel()
        self._half_width = take("feature_half_width").ravel()
        self._prior_mean = take("prior_mean").ravel()
        # Version 1 files hold a constant prior mean only.
        self._prior_slopes = (take("prior_slopes") if version >= 2 else
                              np.zeros((self.state_dim, self._center.size)))
        self._output_std = take("output_std").ravel()
        self.noise_variance = take("noise_variance").ravel()
        self._outputs = [
            _Output(float(take(f"output.{j}.signal_variance")[0, 0]),
                    take(f"output.{j}.lengthscales").ravel(), take(f"output.{j}.points"),
                    take(f"output.{j}.weights").ravel(), take(f"output.{j}.factor"),
                    take(f"output.{j}.sparse_factor"))
            for j in range(self.state_dim)]

    @classmethod
    def load(cls, path: Union[str, "os.PathLike[str]"]) -> "Model":
        """The model in the file at `path` (ModelFileError if it is not one)."""
        with open(path, "rb") as f:
            return cls(f.read())

    def _features(self, z: FloatArray) -> FloatArray:
        columns = []
        for i in range(z.shape[1]):
            if i in self.angle_dims:
                columns += [np.sin(z[:, i]), np.cos(z[:, i])]
            else:
                columns.append(z[:, i])
        return np.stack(columns, axis=1)

    def predict(self, z: npt.ArrayLike, include_noise: bool = False) -> ModelPrediction:
        """Mean and variance of the next state at each row of z = (x, u), as the
        server's Predict: the latent variance, or with `include_noise` that of a
        measured next state."""
        points = np.asarray(z, dtype=np.float64)
        if points.ndim == 1:
            points = points[None, :]
        width = self.state_dim + self.input_dim
        if points.ndim != 2 or points.shape[1] != width:
            raise ValueError(f"z: expected shape (n, {width}), got {np.shape(z)}")
        mean = np.empty((points.shape[0], self.state_dim))
        variance = np.empty_like(mean)
        for first in range(0, points.shape[0], _CHUNK):  # bounds the (m, chunk, F) array
            rows = slice(first, first + _CHUNK)
            self._predict(points[rows], mean[rows], variance[rows], include_noise)
        return ModelPrediction(mean, variance)

    def _predict(self, points: FloatArray, mean: FloatArray, variance: FloatArray,
                 include_noise: bool) -> None:
        normalised = (self._features(points) - self._center) / self._half_width
        prior = self._prior_mean + normalised @ self._prior_slopes.T
        for j, o in enumerate(self._outputs):
            a = normalised / o.lengthscales
            p = o.points / o.lengthscales
            k = o.signal_variance * np.exp(
                -0.5 * ((p[:, None, :] - a[None, :, :]) ** 2).sum(axis=2))  # (m, n)
            scale = self._output_std[j]
            mean[:, j] = prior[:, j] + scale * (k.T @ o.weights)
            if self.delta:
                mean[:, j] += points[:, j]
            v1 = _solve_lower(o.factor, k)
            latent = o.signal_variance - (v1 ** 2).sum(axis=0)
            if o.sparse_factor.size:
                latent += (_solve_lower(o.sparse_factor, v1) ** 2).sum(axis=0)
            variance[:, j] = scale * scale * np.maximum(latent, 0.0)
            if include_noise:
                variance[:, j] += self.noise_variance[j]


def _solve_lower(lower: FloatArray, b: FloatArray) -> FloatArray:
    """lower \\ b by forward substitution, a row at a time (numpy has no triangular
    solve): O(m^2) per column of b."""
    x = np.empty_like(b)
    for i in range(lower.shape[0]):
        x[i] = (b[i] - lower[i, :i] @ x[:i]) / lower[i, i]
    return x


__all__: Tuple[str, ...] = ("Model", "ModelPrediction", "ModelFileError", "FORMAT_VERSION")
