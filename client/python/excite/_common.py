"""What the blocking client (excite.client) and the asyncio client (excite.aio)
share: config parsing, request building, reply conversion, result types, channel
settings. Nothing here makes a call."""

from __future__ import annotations

import dataclasses
import datetime
import difflib
import os
import pathlib
import re
import time
from typing import Any, Dict, Iterable, List, Mapping, Optional, Sequence, Tuple, Union

import grpc
import numpy as np
import numpy.typing as npt
from google.protobuf import json_format, text_format

from excite._pb import config_pb, pb, sim_pb

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
# A session config: a message, a dict in proto field names, a textproto string, or
# the path of a textproto file (see session_config).
ConfigLike = Union[config_pb.SessionConfig, sim_pb.SimConfig, Mapping[str, Any], str,
                   "os.PathLike[str]"]
# A session archive: the message, its serialized bytes, or the path of such a file.
ArchiveLike = Union[pb.SessionArchive, bytes, bytearray, str, "os.PathLike[str]"]
Metadata = Optional[Tuple[Tuple[str, str], ...]]

# Every call about one session carries its id in this header, so that a load
# balancer can route all of a session's calls to the replica that holds it
# (consistent hash on the header; see docs/deployment.md, "Several replicas").
SESSION_HEADER = "x-excite-session"
AUTH_TOKEN_ENV = "EXCITE_AUTH_TOKEN"

_ENUM_PREFIX = {"strategy": "STRATEGY_", "target": "TARGET_", "chooser": "CHOOSER_"}
_ENUM_TYPE: Dict[str, Any] = {"strategy": config_pb.Strategy, "target": config_pb.Target,
                              "chooser": config_pb.AutoConfig.Chooser}
_TOP_LEVEL_ENUMS = ("strategy", "target")
_INTERVAL_FIELDS = ("input_bounds", "state_bounds")
_SERVING_STATUS = {0: "UNKNOWN", 1: "SERVING", 2: "NOT_SERVING", 3: "SERVICE_UNKNOWN"}


# ----------------------------------------------------------------------- results


@dataclasses.dataclass(frozen=True, eq=False)
class Prediction:
    """Predicted next state for each z = (x, u): arrays of shape (n, state_dim)."""

    mean: FloatArray
    variance: FloatArray
    model_version: int


@dataclasses.dataclass(frozen=True, eq=False)
class Plan:
    """A plan from PlanInputs. Arrays have one row per step of the horizon."""

    inputs: FloatArray  # (horizon, input_dim): u_k .. u_{k+horizon-1}
    # (horizon, state_dim), row 0 is the given state; (0, state_dim) for the
    # model-free strategies (prbs, chirp, random).
    predicted_states: FloatArray
    predicted_variances: FloatArray  # like predicted_states: latent variances
    horizon: int  # number of inputs returned
    apply_count: int  # apply this many inputs, then plan again
    objective: float  # summed differential entropy (nats)
    solver_status: str  # e.g. "SOLVER_STATUS_CONVERGED"
    iterations: int
    wall_time_ms: float
    model_version: int
    # The strategy that made the plan, short name: for "auto" the member it drew.
    planned_by: str = ""
    # Steps after the given state at which inputs[0] applies: the number of
    # pending inputs (predicted_states[0] is then the state predicted after them).
    start_step: int = 0

    @property
    def to_apply(self) -> FloatArray:
        """The inputs to apply before planning again, shape (apply_count, input_dim)."""
        return self.inputs[: self.apply_count]


@dataclasses.dataclass(frozen=True)
class AddResult:
    """What one AddData call (``Session.add``) or one closed stream stored.

    ``stored`` transitions were new, ``duplicates`` had a sequence number the
    session already held (a retry: not stored again); the session holds
    ``sample_count`` transitions at ``model_version`` afterwards.
    ``first_sequence`` and ``last_sequence`` are the smallest and largest sequence
    numbers sent (None if nothing was sent)."""

    stored: int
    duplicates: int
    sample_count: int
    model_version: int
    first_sequence: Optional[int] = None
    last_sequence: Optional[int] = None

    @property
    def sent(self) -> int:
        """Transitions the server acknowledged: stored + duplicates."""
        return self.stored + self.duplicates


@dataclasses.dataclass(frozen=True, eq=False)
class Rollout:
    """The model rolled forward (Rollout RPC): x_k ~ N(means[k], covariances[k])
    for k = 0 .. steps, row 0 the given state; variances are the diagonals.
    First-order propagation through the GP (see RolloutResponse)."""

    means: FloatArray  # (steps + 1, state_dim)
    covariances: FloatArray  # (steps + 1, state_dim, state_dim)
    variances: FloatArray  # (steps + 1, state_dim)
    model_version: int


@dataclasses.dataclass(frozen=True, eq=False)
class History:
    """What a session learned as it went (GetSessionHistory), oldest first, as
    arrays; the server keeps it in memory since it loaded the session.

    Plans: ``plan_samples`` (samples each plan was made with), ``plan_objectives``,
    ``plan_wall_time_ms``, ``plan_solver_status`` and ``plan_planned_by`` (short
    strategy names). Learning curve without ground truth: ``error_samples`` and
    ``error_rmse`` (k, state_dim), the one-step RMSE of each batch predicted
    before it was added; ``std_samples`` and ``mean_std`` (k, state_dim), the
    mean predictive std over the region (only with state_bounds)."""

    plan_samples: npt.NDArray[np.int64]
    plan_objectives: FloatArray
    plan_wall_time_ms: FloatArray
    plan_solver_status: Tuple[str, ...]
    plan_planned_by: Tuple[str, ...]
    error_samples: npt.NDArray[np.int64]
    error_rmse: FloatArray
    std_samples: npt.NDArray[np.int64]
    mean_std: FloatArray


@dataclasses.dataclass(frozen=True, eq=False)
class Samples:
    """A session's stored transitions in sequence order (from ExportSession):
    ``states`` and ``next_states`` (n, state_dim), ``inputs`` (n, input_dim),
    ``sequences`` (n,) int64, ``timestamps`` (n,) seconds since the epoch;
    ``state_names``/``input_names`` and their units as the session's config names
    them (empty if it does not)."""

    states: FloatArray
    inputs: FloatArray
    next_states: FloatArray
    sequences: IntArray
    timestamps: FloatArray
    state_names: Tuple[str, ...] = ()
    input_names: Tuple[str, ...] = ()
    state_units: Tuple[str, ...] = ()
    input_units: Tuple[str, ...] = ()

    def __len__(self) -> int:
        return len(self.sequences)

    def to_csv(self, path: Union[str, "os.PathLike[str]"]) -> None:
        """Writes the transitions in excite's one CSV layout (what ``excite add``
        reads and ``excite-sim --trajectory`` writes): a header of the
        dimension names (x0..,u0.. if the config names none) with x.._next for the
        next states and sequence, then one row each, numbers exact (17 significant
        digits). Timestamps are not part of the layout."""
        dx, du = self.states.shape[1], self.inputs.shape[1]
        named = len(self.state_names) == dx and len(self.input_names) == du
        xs = list(self.state_names) if named else [f"x{i}" for i in range(dx)]
        us = list(self.input_names) if named else [f"u{j}" for j in range(du)]
        header = xs + us + [f"{x}_next" for x in xs] + ["sequence"]
        with open(path, "w", encoding="utf-8") as f:
            f.write(",".join(header) + "\n")
            for x, u, x_next, seq in zip(self.states, self.inputs, self.next_states,
                                         self.sequences):
                numbers = [f"{v:.17g}" for v in (*x, *u, *x_next)]
                f.write(",".join(numbers + [str(int(seq))]) + "\n")

    @classmethod
    def from_csv(cls, path: Union[str, "os.PathLike[str]"], state_dim: int,
                 input_dim: int) -> "Samples":
        """Reads that layout (as ``excite add``: blank lines and '#' comments
        skipped, the first row a header if every field is a name). Every row needs
        a sequence number. ValueError naming the line for anything else.
        Timestamps are NaN (unknown); pass ``sequences`` to ``Session.add``."""
        columns = 2 * state_dim + input_dim + 1
        rows: List[List[float]] = []
        sequences: List[int] = []
        first = True
        with open(path, encoding="utf-8") as f:
            for number, line in enumerate(f, start=1):
                line = line.strip()
                if not line or line.startswith("#"):
                    continue
                fields = [v.strip() for v in line.split(",")]
                if first:
                    first = False
                    if all(v[:1].isalpha() or v[:1] == "_" for v in fields) and not any(
                            _is_number(v) for v in fields):
                        continue
                if len(fields) != columns:
                    raise ValueError(
                        f"{path}: line {number}: want {columns} comma-separated fields "
                        f"(x: {state_dim}, u: {input_dim}, x_next: {state_dim}, "
                        f"sequence), found {len(fields)}")
                values = []
                for c, v in enumerate(fields[:-1], start=1):
                    if not _is_number(v) or not np.isfinite(float(v)):
                        raise ValueError(f"{path}: line {number}, column {c}: {v!r} is "
                                         "not a finite number")
                    values.append(float(v))
                if not fields[-1].isdigit():
                    raise ValueError(f"{path}: line {number}: the sequence number "
                                     f"{fields[-1]!r} is not an integer >= 0")
                rows.append(values)
                sequences.append(int(fields[-1]))
        if not rows:
            raise ValueError(f"{path}: no transitions")
        data = np.asarray(rows, dtype=np.float64)
        return cls(states=data[:, :state_dim],
                   inputs=data[:, state_dim:state_dim + input_dim],
                   next_states=data[:, state_dim + input_dim:],
                   sequences=np.asarray(sequences, dtype=np.int64),
                   timestamps=np.full(len(rows), np.nan))


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


# ------------------------------------------------------------------------ config


class SessionView:
    """What both clients' ``Session`` mirror from a ``Session`` message at its last
    refresh; ``info`` is the message itself."""

    info: pb.Session
    name: str
    id: str
    display_name: str
    labels: Dict[str, str]
    create_time: Optional[datetime.datetime]  # UTC; None if the server did not say
    config: config_pb.SessionConfig
    state_dim: int
    input_dim: int
    sample_count: int
    model_version: int
    last_sequence: int
    next_sequence: int  # given to transitions added without explicit numbers
    metadata: Metadata

    def _set(self, info: pb.Session) -> None:
        self.info = info
        self.name = info.name
        self.id = session_id(info.name)
        self.display_name = info.display_name
        self.labels = dict(info.labels)
        self.create_time = (info.create_time.ToDatetime(tzinfo=datetime.timezone.utc)
                            if info.HasField("create_time") else None)
        self.config = info.config
        self.state_dim = info.config.state_dim
        self.input_dim = info.config.input_dim
        self.sample_count = info.sample_count
        self.model_version = info.model_version
        self.last_sequence = info.last_sequence
        self.outputs = info.outputs
        self.next_sequence = info.last_sequence + 1
        self.metadata = session_metadata(self.id)  # see SESSION_HEADER


def _enum_name(key: str, value: Any) -> Any:
    """"rec", "REC" or "STRATEGY_REC" -> "STRATEGY_REC"; ValueError listing the valid
    names for an unknown one. Numbers and other types are left to json_format."""
    if not isinstance(value, str):
        return value
    prefix = _ENUM_PREFIX[key]
    name = value.upper()
    if not name.startswith(prefix):
        name = prefix + name
    valid = [n for n in _ENUM_TYPE[key].keys() if not n.endswith("_UNSPECIFIED")]
    if name not in valid:
        short = ", ".join(n[len(prefix):].lower() for n in valid)
        raise ValueError(f"bad session config: {key} {value!r} is not one of {short} "
                         f"(or their {prefix}* names)")
    return name


def _friendly_dict(config: Mapping[str, Any]) -> dict:
    """Accepts "rec", "REC" or "STRATEGY_REC" for STRATEGY_REC (also in
    auto.members), "delta" for TARGET_DELTA, "portfolio" for auto.chooser's
    CHOOSER_PORTFOLIO and [lo, hi] pairs for intervals, then leaves the rest to
    json_format."""
    result = dict(config)
    for key in _TOP_LEVEL_ENUMS:
        if key in result:
            result[key] = _enum_name(key, result[key])
    if isinstance(result.get("auto"), Mapping):
        auto = dict(result["auto"])
        if auto.get("members") is not None:
            auto["members"] = [_enum_name("strategy", m) for m in auto["members"]]
        if "chooser" in auto:
            auto["chooser"] = _enum_name("chooser", auto["chooser"])
        result["auto"] = auto
    for key in _INTERVAL_FIELDS:
        if key in result:
            result[key] = [
                {"lower": b[0], "upper": b[1]} if isinstance(b, (list, tuple)) else b
                for b in result[key]
            ]
    return result


# A textproto's strings and comments (left alone), or an enum field and its value
# or list of values.
_TEXT_ENUM = re.compile(
    r'("(?:[^"\\\n]|\\.)*"|\'(?:[^\'\\\n]|\\.)*\'|#[^\n]*)'
    r"|\b(strategy|target|members|chooser)(\s*:\s*)(\[[^\]]*\]|[A-Za-z_][A-Za-z0-9_]*)")


def _with_enum_names(text: str) -> str:
    """A textproto with enum values written by their short names in any case
    ("strategy: rec", "members: [Roi, random]") given their enum names, which is
    all protobuf's text parser takes; unknown values are left to its error."""
    def full(key: str, value: str) -> str:
        try:
            return str(_enum_name("strategy" if key == "members" else key, value))
        except ValueError:
            return value

    def replace(m: "re.Match[str]") -> str:
        if m.group(1):
            return m.group(1)
        key, colon, value = m.group(2), m.group(3), m.group(4)
        if value.startswith("["):
            items = re.sub(r"[A-Za-z_][A-Za-z0-9_]*", lambda v: full(key, v.group(0)), value)
            return key + colon + items
        return key + colon + full(key, value)

    return _TEXT_ENUM.sub(replace, text)


def _check_fields(config: Mapping[str, Any], descriptor: Any, path: str) -> None:
    """ValueError naming an unknown field of the dict by its proto (snake_case)
    name, with the valid ones and the nearest (json_format would list camelCase)."""
    for key, value in config.items():
        field = descriptor.fields_by_name.get(key)
        if field is None:
            field = next((f for f in descriptor.fields if f.json_name == key), None)
        if field is None:
            names = sorted(descriptor.fields_by_name)
            near = difflib.get_close_matches(str(key), names, n=1)
            hint = f" (did you mean {near[0]!r}?)" if near else ""
            raise ValueError(f"bad session config: {path}{key!r} is not a field of "
                             f"{descriptor.name}{hint}; its fields: {', '.join(names)}")
        if field.message_type is None:
            continue
        items = value if isinstance(value, list) else [value]
        for i, item in enumerate(items):
            if isinstance(item, Mapping):
                where = f"{path}{key}[{i}]." if isinstance(value, list) else f"{path}{key}."
                _check_fields(item, field.message_type, where)


def _looks_like_a_path(text: str) -> bool:
    """One line with no textproto syntax in it that names a file: a .textproto
    or .txt suffix, or a directory part."""
    return ("\n" not in text and not any(c in text for c in ":{}")
            and (text.endswith((".textproto", ".txt", ".pbtxt")) or "/" in text))


def session_config(config: ConfigLike) -> config_pb.SessionConfig:
    """A ``SessionConfig`` from any of:

    - a ``SessionConfig`` (copied) or a ``SimConfig`` (its ``session``);
    - a dict in proto field names, e.g. ``{"state_dim": 2, "input_dim": 1,
      "input_bounds": [[-3, 3]], "noise": {"variance": 0.05, "fit": True},
      "kernel": {"fit": True}, "strategy": "rec", "horizon": 15}``;
    - a textproto string of a SessionConfig or of a SimConfig;
    - a path (``str`` or ``pathlib.Path``) to such a textproto file, e.g.
      ``sim/configs/pendulum.textproto``.

    Raises ``ValueError`` if it is none of these. The server validates the values.
    """
    if isinstance(config, config_pb.SessionConfig):
        copy = config_pb.SessionConfig()
        copy.CopyFrom(config)
        return copy
    if isinstance(config, sim_pb.SimConfig):
        return session_config(config.session)
    if isinstance(config, Mapping):
        message = config_pb.SessionConfig()
        friendly = _friendly_dict(config)
        _check_fields(friendly, message.DESCRIPTOR, "")
        try:
            json_format.ParseDict(friendly, message)
        except json_format.ParseError as e:
            raise ValueError(f"bad session config: {e}") from e
        return message
    if isinstance(config, os.PathLike) or (
        isinstance(config, str) and "\n" not in config and os.path.isfile(config)
    ):
        with open(config) as f:
            return session_config(f.read())
    if isinstance(config, str) and _looks_like_a_path(config):
        raise FileNotFoundError(f"session config file not found: {config}")
    if isinstance(config, str):
        errors = []
        for kind in (config_pb.SessionConfig, sim_pb.SimConfig):
            parsed = kind()
            try:
                text_format.Parse(_with_enum_names(config), parsed)
            except text_format.ParseError as e:
                errors.append(f"as {kind.__name__}: {e}")
                continue
            return session_config(parsed)
        raise ValueError("not a SessionConfig or SimConfig textproto: " + "; ".join(errors))
    raise ValueError(f"cannot make a SessionConfig from {type(config).__name__}")


def session_archive(archive: ArchiveLike) -> pb.SessionArchive:
    """A ``SessionArchive`` from the message, its bytes or the path of such a file."""
    if isinstance(archive, (str, os.PathLike)):
        archive = pathlib.Path(archive).read_bytes()
    if isinstance(archive, (bytes, bytearray)):
        return pb.SessionArchive.FromString(bytes(archive))
    return archive


# ------------------------------------------------------------ names and headers


def full_name(name: str) -> str:
    """ "sessions/{id}" from "{id}" or "sessions/{id}"."""
    return name if name.startswith("sessions/") else "sessions/" + name


def session_id(name: str) -> str:
    return name.split("/", 1)[-1]


def session_metadata(name_or_id: str) -> Metadata:
    """The routing header for calls about a session (see SESSION_HEADER)."""
    return ((SESSION_HEADER, session_id(name_or_id)),) if name_or_id else None


# ------------------------------------------------------------------------ arrays


def rows(values: npt.ArrayLike, columns: int, what: str) -> FloatArray:
    """values as a 2-D float64 array with `columns` columns (a 1-D array is one row)."""
    array = np.asarray(values, dtype=np.float64)
    if array.ndim == 1:
        array = array.reshape(1, -1)
    if array.ndim != 2 or array.shape[1] != columns:
        raise ValueError(f"{what}: expected shape (n, {columns}), got {np.shape(values)}")
    return array


def transitions(state_dim: int, input_dim: int, next_sequence: int,
                states: npt.ArrayLike, inputs: npt.ArrayLike, next_states: npt.ArrayLike,
                sequences: Optional[npt.ArrayLike] = None,
                timestamps: Optional[npt.ArrayLike] = None,
                ) -> Tuple[List[pb.Transition], int]:
    """The Transition messages for rows of (x, u, x_next), numbered from
    `next_sequence` unless `sequences` is given (timestamps default to now), and the
    next sequence number to use after them."""
    x = rows(states, state_dim, "states")
    u = rows(inputs, input_dim, "inputs")
    y = rows(next_states, state_dim, "next_states")
    n = len(x)
    if len(u) != n or len(y) != n:
        raise ValueError(f"states, inputs, next_states have {n}, {len(u)}, {len(y)} rows")
    seq = (np.arange(next_sequence, next_sequence + n, dtype=np.int64) if sequences is None
           else np.asarray(sequences, dtype=np.int64).reshape(-1))
    stamps = (np.full(n, time.time()) if timestamps is None
              else np.asarray(timestamps, dtype=np.float64).reshape(-1))
    if len(seq) != n or len(stamps) != n:
        raise ValueError("sequences and timestamps need one entry per transition")
    if n:
        next_sequence = max(next_sequence, int(seq.max()) + 1)
    messages = [
        pb.Transition(state=x[i], input=u[i], next_state=y[i],
                      sequence=int(seq[i]), timestamp_s=float(stamps[i]))
        for i in range(n)
    ]
    return messages, next_sequence


def add_requests(name: str, items: Sequence[pb.Transition],
                 batch_size: int) -> List[pb.AddDataRequest]:
    """One AddData stream's messages: `batch_size` transitions each (at least one
    message, so that an empty add still names the session)."""
    if batch_size < 1:
        raise ValueError("batch_size must be at least 1")
    return [
        pb.AddDataRequest(session=name, transitions=items[i:i + batch_size])
        for i in range(0, max(len(items), 1), batch_size)
    ]


def add_result(reply: Union[pb.AddDataResponse, pb.AddDataAck],
               items: Iterable[pb.Transition]) -> AddResult:
    sequences = [t.sequence for t in items]
    return AddResult(
        stored=int(reply.stored), duplicates=int(reply.duplicates),
        sample_count=int(reply.sample_count), model_version=int(reply.model_version),
        first_sequence=min(sequences) if sequences else None,
        last_sequence=max(sequences) if sequences else None)


def predict_request(name: str, state_dim: int, input_dim: int,
                    z: Optional[npt.ArrayLike], states: Optional[npt.ArrayLike],
                    inputs: Optional[npt.ArrayLike],
                    include_noise: bool) -> Tuple[pb.PredictRequest, int]:
    """The PredictRequest for `z` (n, state_dim + input_dim), or `states` and
    `inputs`, and n."""
    if z is None:
        if states is None or inputs is None:
            raise ValueError("give z, or states and inputs")
        x = rows(states, state_dim, "states")
        u = rows(inputs, input_dim, "inputs")
        if len(x) != len(u):
            raise ValueError("states and inputs need the same number of rows")
        z = np.hstack([x, u])
    points = rows(z, state_dim + input_dim, "z")
    request = pb.PredictRequest(session=name, inputs=points.reshape(-1),
                                include_noise=include_noise)
    return request, len(points)


def prediction(reply: pb.PredictResponse, n: int, state_dim: int) -> Prediction:
    shape = (n, state_dim)
    return Prediction(
        mean=np.asarray(reply.mean, dtype=np.float64).reshape(shape),
        variance=np.asarray(reply.variance, dtype=np.float64).reshape(shape),
        model_version=int(reply.model_version),
    )


def plan_request(name: str, state_dim: int, input_dim: int, state: npt.ArrayLike,
                 pending_inputs: Optional[npt.ArrayLike] = None) -> pb.PlanInputsRequest:
    x = np.asarray(state, dtype=np.float64)
    if x.ndim == 2 and x.shape[0] == 1:
        x = x[0]
    if x.ndim != 1 or x.size != state_dim:
        raise ValueError(f"plan takes one state of {state_dim} numbers (the session's "
                         f"state_dim), got shape {x.shape}")
    request = pb.PlanInputsRequest(session=name, state=x)
    if pending_inputs is not None:
        pending = np.asarray(pending_inputs, dtype=np.float64)
        if pending.ndim == 1 and input_dim == 1:  # one input per step
            pending = pending.reshape(-1, 1)
        request.pending_inputs.extend(rows(pending, input_dim, "pending_inputs").ravel())
    return request


def rollout_request(name: str, state_dim: int, input_dim: int, state: npt.ArrayLike,
                    inputs: npt.ArrayLike, state_variance: Optional[npt.ArrayLike],
                    include_noise: bool) -> pb.RolloutRequest:
    x = np.asarray(state, dtype=np.float64)
    if x.shape != (state_dim,):
        raise ValueError(f"rollout: state must be one state of {state_dim} numbers, "
                         f"got shape {x.shape}")
    u = rows(inputs, input_dim, "inputs")
    request = pb.RolloutRequest(session=name, state=x, inputs=u.ravel(),
                                include_noise=include_noise)
    if state_variance is not None:
        request.state_variance.extend(np.asarray(state_variance, dtype=np.float64).ravel())
    return request


def rollout(reply: pb.RolloutResponse, state_dim: int) -> Rollout:
    means = np.asarray(reply.means, dtype=np.float64).reshape(-1, state_dim)
    return Rollout(
        means=means,
        covariances=np.asarray(reply.covariances, dtype=np.float64).reshape(
            -1, state_dim, state_dim),
        variances=np.asarray(reply.variances, dtype=np.float64).reshape(-1, state_dim),
        model_version=int(reply.model_version))


def plan(reply: pb.PlanInputsResponse, state_dim: int, input_dim: int) -> Plan:
    def matrix(values: Iterable[float], columns: int) -> FloatArray:
        return np.asarray(values, dtype=np.float64).reshape(-1, columns)

    return Plan(
        inputs=matrix(reply.inputs, input_dim),
        predicted_states=matrix(reply.predicted_states, state_dim),
        predicted_variances=matrix(reply.predicted_variances, state_dim),
        horizon=int(reply.horizon),
        apply_count=int(reply.apply_count),
        objective=float(reply.objective),
        solver_status=pb.SolverStatus.Name(reply.solver_status),
        iterations=int(reply.iterations),
        wall_time_ms=float(reply.wall_time_ms),
        model_version=int(reply.model_version),
        planned_by=_short_strategy(reply.planned_by),
        start_step=int(reply.start_step),
    )


def _short_strategy(value: int) -> str:
    return config_pb.Strategy.Name(value)[len("STRATEGY_"):].lower() if value else ""


def history(reply: pb.SessionHistory, state_dim: int) -> History:
    def ints(values: Iterable[int]) -> npt.NDArray[np.int64]:
        return np.asarray(list(values), dtype=np.int64)

    def per_dimension(rows: Iterable[Iterable[float]]) -> FloatArray:
        values = [v for row in rows for v in row]
        return np.asarray(values, dtype=np.float64).reshape(-1, state_dim)

    return History(
        plan_samples=ints(p.sample_count for p in reply.plans),
        plan_objectives=np.asarray([p.objective for p in reply.plans], dtype=np.float64),
        plan_wall_time_ms=np.asarray([p.wall_time_ms for p in reply.plans], dtype=np.float64),
        plan_solver_status=tuple(pb.SolverStatus.Name(p.solver_status) for p in reply.plans),
        plan_planned_by=tuple(_short_strategy(p.planned_by) for p in reply.plans),
        error_samples=ints(e.sample_count for e in reply.batch_errors),
        error_rmse=per_dimension(e.rmse for e in reply.batch_errors),
        std_samples=ints(u.sample_count for u in reply.uncertainty),
        mean_std=per_dimension(u.mean_std for u in reply.uncertainty),
    )


def samples(archive: pb.SessionArchive) -> Samples:
    """The samples of an archive as arrays (shapes from its config, so an empty
    session gives (0, state_dim) etc.)."""
    dx, du = archive.config.state_dim, archive.config.input_dim
    items = archive.samples

    def matrix(field: str, columns: int) -> FloatArray:
        values = [v for t in items for v in getattr(t, field)]
        return np.asarray(values, dtype=np.float64).reshape(len(items), columns)

    return Samples(
        states=matrix("state", dx),
        inputs=matrix("input", du),
        next_states=matrix("next_state", dx),
        sequences=np.asarray([t.sequence for t in items], dtype=np.int64),
        timestamps=np.asarray([t.timestamp_s for t in items], dtype=np.float64),
        state_names=tuple(archive.config.state_names),
        input_names=tuple(archive.config.input_names),
        state_units=tuple(archive.config.state_units),
        input_units=tuple(archive.config.input_units),
    )


# ------------------------------------------------------------------------ health


HEALTH_CHECK_METHOD = "/grpc.health.v1.Health/Check"


def health_request(service: str = "") -> bytes:
    """HealthCheckRequest { string service = 1; } encoded by hand (no health stubs)."""
    data = service.encode()
    return b"" if not data else b"\x0a" + _varint(len(data)) + data


def health_status(reply: bytes) -> str:
    """The status name in a HealthCheckResponse { ServingStatus status = 1; }."""
    status, i = 0, 0
    while i < len(reply):
        key, i = _read_varint(reply, i)
        if key != 0x08:
            raise ValueError(f"unexpected field in HealthCheckResponse: {key}")
        status, i = _read_varint(reply, i)
    return _SERVING_STATUS.get(status, f"STATUS_{status}")


def _varint(value: int) -> bytes:
    out = bytearray()
    while True:
        byte = value & 0x7F
        value >>= 7
        if value:
            out.append(byte | 0x80)
        else:
            out.append(byte)
            return bytes(out)


def _read_varint(data: bytes, i: int) -> Tuple[int, int]:
    value, shift = 0, 0
    while True:
        if i >= len(data):
            raise ValueError("truncated varint")
        byte = data[i]
        i += 1
        value |= (byte & 0x7F) << shift
        if not byte & 0x80:
            return value, i
        shift += 7


# ----------------------------------------------------------------------- channel


def channel_options(max_message_mb: int) -> List[Tuple[str, int]]:
    size = max_message_mb * 1024 * 1024
    return [("grpc.max_receive_message_length", size),
            ("grpc.max_send_message_length", size)]


def channel_credentials(tls_ca: Optional[Union[str, "os.PathLike[str]"]],
                        tls_client_cert: Optional[Union[str, "os.PathLike[str]"]],
                        tls_client_key: Optional[Union[str, "os.PathLike[str]"]],
                        ) -> Optional[grpc.ChannelCredentials]:
    """None for plaintext, else TLS (mutual with the client certificate and key)."""
    if (tls_client_cert is None) != (tls_client_key is None):
        raise ValueError("tls_client_cert and tls_client_key go together")
    if tls_client_cert is not None and tls_ca is None:
        raise ValueError("tls_client_cert needs tls_ca (mutual TLS runs over TLS)")
    if tls_ca is None:
        return None

    def read(path: Union[str, "os.PathLike[str]", None]) -> Optional[bytes]:
        return None if path is None else pathlib.Path(path).read_bytes()

    return grpc.ssl_channel_credentials(
        root_certificates=read(tls_ca), private_key=read(tls_client_key),
        certificate_chain=read(tls_client_cert))


def auth_token(token: Optional[str]) -> str:
    """The bearer token to send: `token`, else $EXCITE_AUTH_TOKEN ("" sends none)."""
    return os.environ.get(AUTH_TOKEN_ENV, "") if token is None else token


def auth_header(token: str) -> Tuple[str, str]:
    return ("authorization", f"Bearer {token}")
