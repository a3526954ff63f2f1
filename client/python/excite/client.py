"""A thin, friendly wrapper over the generated ExplorationService stubs.

Arrays are numpy arrays with one row per point; configs can be dicts, textproto
strings or files, or messages. Errors are the server's: ``grpc.RpcError`` with
``.code()`` (NOT_FOUND, INVALID_ARGUMENT, FAILED_PRECONDITION, ...) and
``.details()``. The raw stub is ``Client.stub`` for anything not wrapped here.
"""

import collections
import dataclasses
import os
import pathlib
import queue
import threading
import time

import grpc
import numpy as np
from google.protobuf import json_format, text_format

from excite.errors import CheckedStub, converted
from excite.v1 import exploration_service_pb2 as pb
from excite.v1 import exploration_service_pb2_grpc as pb_grpc
from excite.v1 import session_config_pb2 as config_pb
from excite.v1 import sim_config_pb2 as sim_pb

_ENUM_PREFIX = {"strategy": "STRATEGY_", "target": "TARGET_"}
_INTERVAL_FIELDS = ("input_bounds", "state_bounds")
_SERVING_STATUS = {0: "UNKNOWN", 1: "SERVING", 2: "NOT_SERVING", 3: "SERVICE_UNKNOWN"}
# Every call about one session carries its id in this header, so that a load
# balancer can route all of a session's calls to the replica that holds it
# (consistent hash on the header; see docs/deployment.md, "Several replicas").
SESSION_HEADER = "x-excite-session"


def _session_metadata(name_or_id):
    return ((SESSION_HEADER, name_or_id.split("/", 1)[-1]),) if name_or_id else None


def _friendly_dict(config):
    """Accepts "rec" for STRATEGY_REC, "delta" for TARGET_DELTA and [lo, hi] pairs
    for intervals, then leaves the rest to json_format."""
    config = dict(config)
    for key, prefix in _ENUM_PREFIX.items():
        value = config.get(key)
        if isinstance(value, str) and not value.upper().startswith(prefix):
            config[key] = prefix + value.upper()
    for key in _INTERVAL_FIELDS:
        if key in config:
            config[key] = [
                {"lower": b[0], "upper": b[1]} if isinstance(b, (list, tuple)) else b
                for b in config[key]
            ]
    return config


def session_config(config):
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
    if isinstance(config, dict):
        message = config_pb.SessionConfig()
        try:
            json_format.ParseDict(_friendly_dict(config), message)
        except json_format.ParseError as e:
            raise ValueError(f"bad session config: {e}") from e
        return message
    if isinstance(config, pathlib.Path) or (
        isinstance(config, str) and "\n" not in config and os.path.isfile(config)
    ):
        with open(config) as f:
            return session_config(f.read())
    if isinstance(config, str):
        errors = []
        for kind in (config_pb.SessionConfig, sim_pb.SimConfig):
            message = kind()
            try:
                text_format.Parse(config, message)
            except text_format.ParseError as e:
                errors.append(f"as {kind.DESCRIPTOR.name}: {e}")
                continue
            return session_config(message)
        raise ValueError("not a SessionConfig or SimConfig textproto: " + "; ".join(errors))
    raise ValueError(f"cannot make a SessionConfig from {type(config).__name__}")


def _rows(values, columns, what):
    """values as a 2-D float64 array with `columns` columns (a 1-D array is one row)."""
    array = np.asarray(values, dtype=np.float64)
    if array.ndim == 1:
        array = array.reshape(1, -1)
    if array.ndim != 2 or array.shape[1] != columns:
        raise ValueError(f"{what}: expected shape (n, {columns}), got {np.shape(values)}")
    return array


@dataclasses.dataclass
class Prediction:
    """Predicted next state for each z = (x, u): arrays of shape (n, state_dim)."""

    mean: np.ndarray
    variance: np.ndarray
    model_version: int


@dataclasses.dataclass
class Plan:
    """A plan from PlanInputs. Arrays have one row per step of the horizon."""

    inputs: np.ndarray  # (horizon, input_dim): u_k .. u_{k+horizon-1}
    # (horizon, state_dim), row 0 is the given state; (0, state_dim) for the
    # model-free strategies (prbs, chirp, random).
    predicted_states: np.ndarray
    predicted_variances: np.ndarray  # like predicted_states: latent variances
    horizon: int  # number of inputs returned
    apply_count: int  # apply this many inputs, then plan again
    objective: float  # summed differential entropy (nats)
    solver_status: str  # e.g. "SOLVER_STATUS_CONVERGED"
    iterations: int
    wall_time_ms: float
    model_version: int

    @property
    def to_apply(self):
        """The inputs to apply before planning again, shape (apply_count, input_dim)."""
        return self.inputs[: self.apply_count]


class _BearerToken(grpc.UnaryUnaryClientInterceptor,
                   grpc.StreamUnaryClientInterceptor):
    """Adds "authorization: Bearer <token>" to every call (plaintext loopback
    included, where gRPC's call credentials would refuse to send it)."""

    def __init__(self, token):
        self._header = ("authorization", f"Bearer {token}")

    def _with_token(self, details):
        return _CallDetails(details.method, details.timeout,
                            list(details.metadata or []) + [self._header],
                            details.credentials, details.wait_for_ready,
                            getattr(details, "compression", None))

    def intercept_unary_unary(self, continuation, details, request):
        return continuation(self._with_token(details), request)

    def intercept_stream_unary(self, continuation, details, request_iterator):
        return continuation(self._with_token(details), request_iterator)


class _CallDetails(
        collections.namedtuple("_CallDetails", ("method", "timeout", "metadata",
                                                "credentials", "wait_for_ready",
                                                "compression")),
        grpc.ClientCallDetails):
    pass


class Client:
    """A connection to excite-server. Thread-safe; close it (or use ``with``)."""

    def __init__(self, target="127.0.0.1:50051", *, timeout_s=30.0, plan_timeout_s=60.0,
                 max_message_mb=64, tls_ca=None, tls_client_cert=None, tls_client_key=None,
                 auth_token=None):
        """`target` is "host:port". Every call gets `timeout_s` as its deadline,
        PlanInputs `plan_timeout_s` (solves can take a while).

        Security, as the C++ clients' flags: `tls_ca` (path of the PEM CA bundle that
        signed the server's certificate) turns TLS on; `tls_client_cert` and
        `tls_client_key` (paths, both or neither) add mutual TLS; `auth_token` is
        sent as "authorization: Bearer <token>" on every call (default: the
        EXCITE_AUTH_TOKEN environment variable; "" sends none)."""
        size = max_message_mb * 1024 * 1024
        self.target = target
        options = [
            ("grpc.max_receive_message_length", size),
            ("grpc.max_send_message_length", size),
        ]
        if (tls_client_cert is None) != (tls_client_key is None):
            raise ValueError("tls_client_cert and tls_client_key go together")
        if tls_client_cert is not None and tls_ca is None:
            raise ValueError("tls_client_cert needs tls_ca (mutual TLS runs over TLS)")
        if tls_ca is None:
            channel = grpc.insecure_channel(target, options=options)
        else:
            read = lambda path: pathlib.Path(path).read_bytes()  # noqa: E731
            credentials = grpc.ssl_channel_credentials(
                root_certificates=read(tls_ca),
                private_key=read(tls_client_key) if tls_client_key else None,
                certificate_chain=read(tls_client_cert) if tls_client_cert else None)
            channel = grpc.secure_channel(target, credentials, options=options)
        if auth_token is None:
            auth_token = os.environ.get("EXCITE_AUTH_TOKEN", "")
        self._raw_channel = channel
        self.channel = (grpc.intercept_channel(channel, _BearerToken(auth_token))
                        if auth_token else channel)
        self.stub = CheckedStub(pb_grpc.ExplorationServiceStub(self.channel))
        self.timeout_s = timeout_s
        self.plan_timeout_s = plan_timeout_s
        # grpc.health.v1.Health/Check with raw bytes: its two one-field messages
        # are encoded by hand below, so no health stubs are needed.
        self._health_check = self.channel.unary_unary("/grpc.health.v1.Health/Check")

    def close(self):
        self._raw_channel.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def wait_for_ready(self, timeout_s=10.0):
        """Blocks until the channel is connected; ``grpc.FutureTimeoutError`` if not
        within `timeout_s`."""
        grpc.channel_ready_future(self._raw_channel).result(timeout=timeout_s)

    def health(self, service=""):
        """The grpc.health.v1 status name ("SERVING", "NOT_SERVING", ...)."""
        data = service.encode()
        request = b"" if not data else b"\x0a" + _varint(len(data)) + data
        reply = self._health_check(request, timeout=self.timeout_s)
        status, i = 0, 0
        while i < len(reply):  # HealthCheckResponse { ServingStatus status = 1; }
            key, i = _read_varint(reply, i)
            if key != 0x08:
                raise ValueError(f"unexpected field in HealthCheckResponse: {key}")
            status, i = _read_varint(reply, i)
        return _SERVING_STATUS.get(status, f"STATUS_{status}")

    def create_session(self, config, session_id=""):
        """Creates a session (see :func:`session_config` for `config`); returns it."""
        request = pb.CreateSessionRequest(session_id=session_id, config=session_config(config))
        return Session(self, self.stub.CreateSession(
            request, timeout=self.timeout_s, metadata=_session_metadata(session_id)))

    def session(self, name):
        """The session "sessions/{id}" (or just "{id}"); NOT_FOUND if there is none."""
        request = pb.GetSessionRequest(name=_full_name(name))
        return Session(self, self.stub.GetSession(
            request, timeout=self.timeout_s, metadata=_session_metadata(name)))

    def list_sessions(self, page_size=0):
        """Iterates over every session, fetching pages of `page_size` (0: server's
        default)."""
        token = ""
        while True:
            page = self.stub.ListSessions(
                pb.ListSessionsRequest(page_size=page_size, page_token=token),
                timeout=self.timeout_s,
            )
            for info in page.sessions:
                yield Session(self, info)
            token = page.next_page_token
            if not token:
                return

    def delete_session(self, name):
        self.stub.DeleteSession(
            pb.DeleteSessionRequest(name=_full_name(name)), timeout=self.timeout_s,
            metadata=_session_metadata(name),
        )

    def export_session(self, name, path=None):
        """The session "sessions/{id}" (or "{id}") as a ``SessionArchive`` message:
        config, every sample, last fitted hyperparameters. With `path`, also writes
        it there in the format of ``excite export`` (the serialized message).
        RESOURCE_EXHAUSTED if it is larger than the server's or this client's
        message limit (``max_message_mb``)."""
        archive = self.stub.ExportSession(
            pb.ExportSessionRequest(name=_full_name(name)), timeout=self.timeout_s,
            metadata=_session_metadata(name))
        if path is not None:
            pathlib.Path(path).write_bytes(archive.SerializeToString())
        return archive

    def import_session(self, archive, session_id=None):
        """Creates a session from `archive`: a ``SessionArchive``, its serialized
        bytes, or the path (``str`` / ``pathlib.Path``) of a file written by
        ``excite export`` or :meth:`export_session`. The new session's id is
        `session_id`, else the archive's. All or nothing on the server; returns the
        :class:`Session`."""
        if isinstance(archive, (str, pathlib.Path)):
            archive = pathlib.Path(archive).read_bytes()
        if isinstance(archive, (bytes, bytearray)):
            archive = pb.SessionArchive.FromString(bytes(archive))
        request = pb.ImportSessionRequest(archive=archive, session_id=session_id or "")
        return Session(self, self.stub.ImportSession(
            request, timeout=self.timeout_s,
            metadata=_session_metadata(session_id or archive.session_id)))


class Session:
    """One session: its GP model lives on the server.

    Attributes mirror the ``Session`` message at the last refresh: ``name``,
    ``config``, ``sample_count``, ``model_version``, ``last_sequence``, ``outputs``
    (per-dimension hyperparameters); ``info`` is the message itself.
    """

    def __init__(self, client, info):
        self.client = client
        self._set(info)

    def _set(self, info):
        self.info = info
        self.name = info.name
        self.id = info.name.split("/", 1)[-1]
        self.config = info.config
        self.state_dim = info.config.state_dim
        self.input_dim = info.config.input_dim
        self.sample_count = info.sample_count
        self.model_version = info.model_version
        self.last_sequence = info.last_sequence
        self.outputs = info.outputs
        # Sequence numbers given to transitions added without explicit ones.
        self.next_sequence = info.last_sequence + 1
        self.metadata = _session_metadata(self.id)  # see SESSION_HEADER

    def __repr__(self):
        return (f"Session({self.name!r}, state_dim={self.state_dim}, "
                f"input_dim={self.input_dim}, samples={self.sample_count})")

    def refresh(self):
        """Re-reads the session from the server; returns self."""
        self._set(self.client.stub.GetSession(
            pb.GetSessionRequest(name=self.name), timeout=self.client.timeout_s,
            metadata=self.metadata))
        return self

    def delete(self):
        self.client.delete_session(self.name)

    def _transitions(self, states, inputs, next_states, sequences, timestamps):
        x = _rows(states, self.state_dim, "states")
        u = _rows(inputs, self.input_dim, "inputs")
        y = _rows(next_states, self.state_dim, "next_states")
        n = len(x)
        if len(u) != n or len(y) != n:
            raise ValueError(f"states, inputs, next_states have {n}, {len(u)}, {len(y)} rows")
        if sequences is None:
            sequences = np.arange(self.next_sequence, self.next_sequence + n)
        sequences = np.asarray(sequences, dtype=np.int64).reshape(-1)
        if timestamps is None:
            timestamps = np.full(n, time.time())
        timestamps = np.asarray(timestamps, dtype=np.float64).reshape(-1)
        if len(sequences) != n or len(timestamps) != n:
            raise ValueError("sequences and timestamps need one entry per transition")
        if n:
            self.next_sequence = max(self.next_sequence, int(sequences.max()) + 1)
        return [
            pb.Transition(state=x[i], input=u[i], next_state=y[i],
                          sequence=int(sequences[i]), timestamp_s=float(timestamps[i]))
            for i in range(n)
        ]

    def add(self, states, inputs, next_states, *, sequences=None, timestamps=None,
            batch_size=256):
        """Streams transitions (x_k, u_k applied, x_{k+1} measured) in one AddData
        call, `batch_size` per message. Arrays: (n, state_dim), (n, input_dim),
        (n, state_dim), or 1-D for one transition. Sequence numbers default to
        consecutive numbers after the last stored one (re-sending the same numbers
        is safe: duplicates are not stored twice). Returns the AddDataResponse
        (stored, duplicates, sample_count, model_version)."""
        transitions = self._transitions(states, inputs, next_states, sequences, timestamps)
        requests = [
            pb.AddDataRequest(session=self.name, transitions=transitions[i:i + batch_size])
            for i in range(0, max(len(transitions), 1), batch_size)
        ]
        reply = self.client.stub.AddData(iter(requests), timeout=self.client.timeout_s,
                                         metadata=self.metadata)
        self.sample_count = reply.sample_count
        self.model_version = reply.model_version
        return reply

    def stream(self, batch_size=32, timeout_s=None):
        """A long-lived StreamData stream for logging transitions as they happen::

            with session.stream() as s:
                s.send(x, u, x_next)   # repeatedly
            print(s.result.stored, s.acknowledged)

        Transitions go out in messages of `batch_size` (and whatever is left when
        the stream closes). The server stores each message, then acknowledges it:
        `acknowledged` counts the transitions known to be stored, and after a broken
        stream `unacknowledged()` lists those to resend (with the same sequence
        numbers, so nothing is stored twice)."""
        return TransitionStream(self, batch_size, timeout_s)

    def predict(self, z=None, *, states=None, inputs=None, include_noise=False):
        """Predicted next state for a batch: `z` of shape (n, state_dim + input_dim),
        or `states` (n, state_dim) and `inputs` (n, input_dim). Returns a
        :class:`Prediction` with mean and variance of shape (n, state_dim)."""
        if z is None:
            if states is None or inputs is None:
                raise ValueError("give z, or states and inputs")
            x = _rows(states, self.state_dim, "states")
            u = _rows(inputs, self.input_dim, "inputs")
            if len(x) != len(u):
                raise ValueError("states and inputs need the same number of rows")
            z = np.hstack([x, u])
        z = _rows(z, self.state_dim + self.input_dim, "z")
        reply = self.client.stub.Predict(
            pb.PredictRequest(session=self.name, inputs=z.reshape(-1),
                              include_noise=include_noise),
            timeout=self.client.timeout_s,
            metadata=self.metadata,
        )
        shape = (len(z), self.state_dim)
        return Prediction(
            mean=np.asarray(reply.mean, dtype=np.float64).reshape(shape),
            variance=np.asarray(reply.variance, dtype=np.float64).reshape(shape),
            model_version=reply.model_version,
        )

    def plan(self, state):
        """The inputs to apply from the measured `state` (state_dim numbers)."""
        x = _rows(state, self.state_dim, "state")
        if len(x) != 1:
            raise ValueError("plan takes one state")
        reply = self.client.stub.PlanInputs(
            pb.PlanInputsRequest(session=self.name, state=x[0]),
            timeout=self.client.plan_timeout_s,
            metadata=self.metadata,
        )
        def rows(values, columns):
            return np.asarray(values, dtype=np.float64).reshape(-1, columns)

        return Plan(
            inputs=rows(reply.inputs, self.input_dim),
            predicted_states=rows(reply.predicted_states, self.state_dim),
            predicted_variances=rows(reply.predicted_variances, self.state_dim),
            horizon=reply.horizon,
            apply_count=reply.apply_count,
            objective=reply.objective,
            solver_status=pb.SolverStatus.Name(reply.solver_status),
            iterations=reply.iterations,
            wall_time_ms=reply.wall_time_ms,
            model_version=reply.model_version,
        )


class TransitionStream:
    """See :meth:`Session.stream`."""

    _END = object()

    def __init__(self, session, batch_size, timeout_s):
        self.session = session
        self.batch_size = batch_size
        self.timeout_s = timeout_s
        self.result = None  # an AddDataResponse summing the acknowledgements, once closed
        self.acknowledged = 0  # transitions acknowledged (stored, or already stored)
        self._pending = []
        self._sent = collections.deque()  # messages sent and not yet acknowledged
        self._queue = queue.Queue()
        self._lock = threading.Lock()
        self._stored = 0
        self._duplicates = 0
        self._last_ack = None
        self._error = None
        self._call = None
        self._reader = None

    def _requests(self):
        first = True
        while True:
            item = self._queue.get()
            if item is self._END:
                return
            yield pb.AddDataRequest(session=self.session.name if first else "",
                                    transitions=item)
            first = False

    def _read_acks(self):
        try:
            for ack in self._call:
                with self._lock:
                    acked = self._sent.popleft()
                    self.acknowledged += len(acked)
                    self._stored += ack.stored
                    self._duplicates += ack.duplicates
                    self._last_ack = ack
        except grpc.RpcError as error:
            self._error = converted(error)

    def __enter__(self):
        self._call = self.session.client.stub.StreamData(
            self._requests(), timeout=self.timeout_s, metadata=self.session.metadata)
        self._reader = threading.Thread(target=self._read_acks, daemon=True)
        self._reader.start()
        return self

    def _flush(self):  # with self._lock held
        if self._pending:
            self._sent.append(self._pending)
            self._queue.put(self._pending)
            self._pending = []

    def send(self, state, input, next_state, *, sequence=None, timestamp=None):
        """Queues one transition (1-D arrays). Raises the stream's error if it failed."""
        if self._error is not None:
            raise self._error
        with self._lock:
            (transition,) = self.session._transitions(
                state, input, next_state,
                None if sequence is None else [sequence],
                None if timestamp is None else [timestamp])
            self._pending.append(transition)
            if len(self._pending) >= self.batch_size:
                self._flush()

    def unacknowledged(self):
        """The transitions sent or queued but not acknowledged (resend these)."""
        with self._lock:
            return [t for message in self._sent for t in message] + list(self._pending)

    def close(self):
        """Sends what is pending, waits for every acknowledgement, ends the stream and
        returns an AddDataResponse summing them. Raises the stream's error, or
        RuntimeError if the server ended it before acknowledging everything."""
        with self._lock:
            self._flush()
        self._queue.put(self._END)
        self._reader.join()
        if self._error is not None:
            raise self._error
        if self._sent:  # ended cleanly early: e.g. at a message it could not parse
            raise RuntimeError(
                f"the server ended the stream with {len(self.unacknowledged())} "
                "transitions unacknowledged (not stored): resend stream.unacknowledged()")
        last = self._last_ack
        self.result = pb.AddDataResponse(
            stored=self._stored, duplicates=self._duplicates,
            sample_count=last.sample_count if last else self.session.sample_count,
            model_version=last.model_version if last else self.session.model_version)
        self.session.sample_count = self.result.sample_count
        self.session.model_version = self.result.model_version
        return self.result

    def __exit__(self, exc_type, *rest):
        if exc_type is None:
            self.close()
        else:
            self._call.cancel()
            self._queue.put(self._END)  # unblocks the request iterator


def _full_name(name):
    return name if name.startswith("sessions/") else "sessions/" + name


def _varint(value):
    out = bytearray()
    while True:
        byte = value & 0x7F
        value >>= 7
        if value:
            out.append(byte | 0x80)
        else:
            out.append(byte)
            return bytes(out)


def _read_varint(data, i):
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
