"""A thin, friendly, blocking wrapper over the generated ExplorationService stubs.

Arrays are numpy arrays with one row per point; configs can be dicts, textproto
strings or files, or messages. Errors are the server's: ``grpc.RpcError`` with
``.code()`` (NOT_FOUND, INVALID_ARGUMENT, FAILED_PRECONDITION, ...) and
``.details()``; INVALID_ARGUMENT is :class:`excite.InvalidArgument`. The raw stub
is ``Client.stub`` for anything not wrapped here. The asyncio twin is
:mod:`excite.aio`.
"""

from __future__ import annotations

import collections
import os
import queue
import threading
from typing import Any, Iterator, List, Mapping, Optional, Union

import grpc
import numpy.typing as npt

from excite import _common
from excite._common import (  # noqa: F401  (re-exported: excite.client.X still works)
    SESSION_HEADER,
    AddResult,
    ArchiveLike,
    ConfigLike,
    History,
    Rollout,
    Plan,
    Prediction,
    Samples,
    session_config,
)
from excite._pb import config_pb, pb, pb_grpc
from excite.errors import CheckedStub, converted
from excite.model import Model

PathLike = Union[str, "os.PathLike[str]"]


class _CallDetails(
        collections.namedtuple("_CallDetails", ("method", "timeout", "metadata",
                                                "credentials", "wait_for_ready",
                                                "compression")),
        grpc.ClientCallDetails):
    pass


class _BearerToken(grpc.UnaryUnaryClientInterceptor, grpc.StreamUnaryClientInterceptor,
                   grpc.UnaryStreamClientInterceptor, grpc.StreamStreamClientInterceptor):
    """Adds "authorization: Bearer <token>" to every call (plaintext loopback
    included, where gRPC's call credentials would refuse to send it)."""

    def __init__(self, token: str) -> None:
        self._header = _common.auth_header(token)

    def _with_token(self, details: Any) -> _CallDetails:
        return _CallDetails(details.method, details.timeout,
                            list(details.metadata or []) + [self._header],
                            details.credentials, details.wait_for_ready,
                            getattr(details, "compression", None))

    def _intercept(self, continuation: Any, details: Any, request: Any) -> Any:
        return continuation(self._with_token(details), request)

    intercept_unary_unary = _intercept
    intercept_stream_unary = _intercept
    intercept_unary_stream = _intercept
    intercept_stream_stream = _intercept


class Client:
    """A connection to excite-server. Thread-safe; close it (or use ``with``)."""

    def __init__(self, target: str = "127.0.0.1:50051", *, timeout_s: float = 30.0,
                 plan_timeout_s: float = 60.0, max_message_mb: int = 64,
                 tls_ca: Optional[PathLike] = None,
                 tls_client_cert: Optional[PathLike] = None,
                 tls_client_key: Optional[PathLike] = None,
                 auth_token: Optional[str] = None,
                 retry_unavailable_s: float = 0.0) -> None:
        """`target` is "host:port". Every call gets `timeout_s` as its deadline,
        PlanInputs `plan_timeout_s` (solves can take a while).

        `retry_unavailable_s` > 0 resends a call that failed UNAVAILABLE (a server
        restarting, a replica failing over) for that many seconds, as the C++
        client does: reads and PlanInputs also after a lost answer, AddData also
        after a deadline (its sequence numbers make a resent batch a duplicate).
        Errors are ``excite.ExciteError`` subclasses, one per status.

        Security, as the C++ clients' flags: `tls_ca` (path of the PEM CA bundle that
        signed the server's certificate) turns TLS on; `tls_client_cert` and
        `tls_client_key` (paths, both or neither) add mutual TLS; `auth_token` is
        sent as "authorization: Bearer <token>" on every call (default: the
        EXCITE_AUTH_TOKEN environment variable; "" sends none)."""
        self.target = target
        options = _common.channel_options(max_message_mb)
        credentials = _common.channel_credentials(tls_ca, tls_client_cert, tls_client_key)
        channel = (grpc.insecure_channel(target, options=options) if credentials is None
                   else grpc.secure_channel(target, credentials, options=options))
        token = _common.auth_token(auth_token)
        self._raw_channel = channel
        self.channel: grpc.Channel = (
            grpc.intercept_channel(channel, _BearerToken(token)) if token else channel)
        self.stub: Any = CheckedStub(pb_grpc.ExplorationServiceStub(self.channel),
                                     retry_unavailable_s)
        self.timeout_s = timeout_s
        self.plan_timeout_s = plan_timeout_s
        # grpc.health.v1.Health/Check with raw bytes (no health stubs needed).
        self._health_check = self.channel.unary_unary(_common.HEALTH_CHECK_METHOD)

    def close(self) -> None:
        self._raw_channel.close()

    def __enter__(self) -> Client:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def wait_for_ready(self, timeout_s: float = 10.0) -> None:
        """Blocks until the channel is connected; ``grpc.FutureTimeoutError`` if not
        within `timeout_s`."""
        grpc.channel_ready_future(self._raw_channel).result(timeout=timeout_s)

    def health(self, service: str = "") -> str:
        """The grpc.health.v1 status name ("SERVING", "NOT_SERVING", ...)."""
        reply = self._health_check(_common.health_request(service), timeout=self.timeout_s)
        return _common.health_status(reply)

    def create_session(self, config: ConfigLike, session_id: str = "",
                       display_name: str = "",
                       labels: Optional[Mapping[str, str]] = None) -> Session:
        """Creates a session (see :func:`session_config` for `config`); returns it.
        `labels` (keys and values of a-z, 0-9, _ and -) can be filtered on in
        :meth:`list_sessions`."""
        request = pb.CreateSessionRequest(session_id=session_id, config=session_config(config),
                                          display_name=display_name, labels=labels or {})
        return Session(self, self.stub.CreateSession(
            request, timeout=self.timeout_s, metadata=_common.session_metadata(session_id)))

    def session(self, name: str) -> Session:
        """The session "sessions/{id}" (or just "{id}"); NOT_FOUND if there is none."""
        request = pb.GetSessionRequest(name=_common.full_name(name))
        return Session(self, self.stub.GetSession(
            request, timeout=self.timeout_s, metadata=_common.session_metadata(name)))

    def list_sessions(self, page_size: int = 0, filter: str = "") -> Iterator[Session]:
        """Iterates over every session whose labels match `filter` (e.g.
        ``'labels.plant = "pendulum" AND labels.run:*'``; empty: all), fetching
        pages of `page_size` (0: server's default)."""
        token = ""
        while True:
            page = self.stub.ListSessions(
                pb.ListSessionsRequest(page_size=page_size, page_token=token, filter=filter),
                timeout=self.timeout_s,
            )
            for info in page.sessions:
                yield Session(self, info)
            token = page.next_page_token
            if not token:
                return

    def delete_session(self, name: str) -> None:
        self.stub.DeleteSession(
            pb.DeleteSessionRequest(name=_common.full_name(name)), timeout=self.timeout_s,
            metadata=_common.session_metadata(name),
        )

    def export_session(self, name: str, path: Optional[PathLike] = None) -> pb.SessionArchive:
        """The session "sessions/{id}" (or "{id}") as a ``SessionArchive`` message:
        config, every sample, last fitted hyperparameters. With `path`, also writes
        it there in the format of ``excite export`` (the serialized message).
        RESOURCE_EXHAUSTED if it is larger than the server's or this client's
        message limit (``max_message_mb``)."""
        archive = self.stub.ExportSession(
            pb.ExportSessionRequest(name=_common.full_name(name)), timeout=self.timeout_s,
            metadata=_common.session_metadata(name))
        if path is not None:
            with open(path, "wb") as f:
                f.write(archive.SerializeToString())
        return archive

    def import_session(self, archive: ArchiveLike, session_id: Optional[str] = None) -> Session:
        """Creates a session from `archive`: a ``SessionArchive``, its serialized
        bytes, or the path (``str`` / ``pathlib.Path``) of a file written by
        ``excite export`` or :meth:`export_session`. The new session's id is
        `session_id`, else the archive's. All or nothing on the server; returns the
        :class:`Session`."""
        message = _common.session_archive(archive)
        request = pb.ImportSessionRequest(archive=message, session_id=session_id or "")
        return Session(self, self.stub.ImportSession(
            request, timeout=self.timeout_s,
            metadata=_common.session_metadata(session_id or message.session_id)))


class Session(_common.SessionView):
    """One session: its GP model lives on the server.

    Attributes mirror the ``Session`` message at the last refresh (see
    :class:`excite._common.SessionView`): ``name``, ``display_name``, ``labels``,
    ``create_time``, ``config``, ``sample_count``, ``model_version``,
    ``last_sequence``, ``outputs`` (per-dimension hyperparameters); ``info`` is the
    message itself.
    """

    client: Client

    def __init__(self, client: Client, info: pb.Session) -> None:
        self.client = client
        # This object's streams that are open: plan() flushes them first.
        self._open_streams: List[TransitionStream] = []
        self._set(info)

    def __repr__(self) -> str:
        return (f"Session({self.name!r}, state_dim={self.state_dim}, "
                f"input_dim={self.input_dim}, samples={self.sample_count})")

    def refresh(self) -> Session:
        """Re-reads the session from the server; returns self."""
        self._set(self.client.stub.GetSession(
            pb.GetSessionRequest(name=self.name), timeout=self.client.timeout_s,
            metadata=self.metadata))
        return self

    def delete(self) -> None:
        self.client.delete_session(self.name)

    def _transitions(self, states: npt.ArrayLike, inputs: npt.ArrayLike,
                     next_states: npt.ArrayLike, sequences: Optional[npt.ArrayLike],
                     timestamps: Optional[npt.ArrayLike]) -> List[pb.Transition]:
        items, self.next_sequence = _common.transitions(
            self.state_dim, self.input_dim, self.next_sequence, states, inputs,
            next_states, sequences, timestamps)
        return items

    def add(self, states: npt.ArrayLike, inputs: npt.ArrayLike, next_states: npt.ArrayLike,
            *, sequences: Optional[npt.ArrayLike] = None,
            timestamps: Optional[npt.ArrayLike] = None, batch_size: int = 256) -> AddResult:
        """Streams transitions (x_k, u_k applied, x_{k+1} measured) in one AddData
        call, `batch_size` per message. Arrays: (n, state_dim), (n, input_dim),
        (n, state_dim), or 1-D for one transition. Sequence numbers default to
        consecutive numbers after the last stored one (re-sending the same numbers
        is safe: duplicates are not stored twice). Returns an :class:`AddResult`
        (stored, duplicates, sample_count, model_version, first_sequence,
        last_sequence)."""
        items = self._transitions(states, inputs, next_states, sequences, timestamps)
        requests = _common.add_requests(self.name, items, batch_size)
        reply = self.client.stub.AddData(iter(requests), timeout=self.client.timeout_s,
                                         metadata=self.metadata)
        result = _common.add_result(reply, items)
        self.sample_count = result.sample_count
        self.model_version = result.model_version
        return result

    def stream(self, batch_size: int = 32, timeout_s: Optional[float] = None
               ) -> TransitionStream:
        """A long-lived StreamData stream for logging transitions as they happen::

            with session.stream() as s:
                s.send(x, u, x_next)   # repeatedly
            print(s.result.stored, s.acknowledged)

        Transitions go out in messages of `batch_size` (and whatever is left when
        the stream closes). The server stores each message, then acknowledges it:
        `acknowledged` counts the transitions known to be stored, and after a broken
        stream `unacknowledged()` lists those to resend (with the same sequence
        numbers, so nothing is stored twice).

        `send()` returns before the transition is stored. Call `flush()` before
        anything that must see it (a Predict, another client's plan); this
        session's own `plan()` flushes its open streams first."""
        return TransitionStream(self, batch_size, timeout_s)

    def predict(self, z: Optional[npt.ArrayLike] = None, *,
                states: Optional[npt.ArrayLike] = None,
                inputs: Optional[npt.ArrayLike] = None,
                include_noise: bool = False) -> Prediction:
        """Predicted next state for a batch: `z` of shape (n, state_dim + input_dim),
        or `states` (n, state_dim) and `inputs` (n, input_dim). Returns a
        :class:`Prediction` with mean and variance of shape (n, state_dim)."""
        request, n = _common.predict_request(self.name, self.state_dim, self.input_dim,
                                             z, states, inputs, include_noise)
        reply = self.client.stub.Predict(request, timeout=self.client.timeout_s,
                                         metadata=self.metadata)
        return _common.prediction(reply, n, self.state_dim)

    def plan(self, state: npt.ArrayLike, pending_inputs: Optional[npt.ArrayLike] = None
             ) -> Plan:
        """The inputs to apply from the measured `state` (state_dim numbers). Flushes
        this session's open streams first, so the plan sees what they sent.

        `pending_inputs` ((P, input_dim), P <= horizon): inputs the plant applies from
        `state` while this plan is computed; the plan then starts P steps later, from
        the state the model predicts after them (``Plan.start_step`` is P)."""
        request = _common.plan_request(self.name, self.state_dim, self.input_dim, state,
                                       pending_inputs)
        for stream in list(self._open_streams):
            stream.flush()
        reply = self.client.stub.PlanInputs(request, timeout=self.client.plan_timeout_s,
                                            metadata=self.metadata)
        return _common.plan(reply, self.state_dim, self.input_dim)

    def rollout(self, state: npt.ArrayLike, inputs: npt.ArrayLike, *,
                state_variance: Optional[npt.ArrayLike] = None,
                include_noise: bool = False) -> Rollout:
        """The model rolled forward from `state` along `inputs` ((steps, input_dim),
        e.g. ``plan.inputs``): the mean trajectory and each step's covariance
        (:class:`Rollout`). `state_variance`: x_0's variance per dimension;
        `include_noise`: the distribution of measured rather than true states."""
        request = _common.rollout_request(self.name, self.state_dim, self.input_dim, state,
                                          inputs, state_variance, include_noise)
        reply = self.client.stub.Rollout(request, timeout=self.client.timeout_s,
                                         metadata=self.metadata)
        return _common.rollout(reply, self.state_dim)

    def export_model(self, path: Optional[PathLike] = None) -> Model:
        """The session's fitted model as a :class:`excite.Model` that predicts without
        a server; with `path`, its model file is also written there (read it back
        with ``excite.Model.load(path)``, or in C++ with ``excite::LoadedModel``)."""
        reply = self.client.stub.ExportModel(pb.ExportModelRequest(name=self.name),
                                             timeout=self.client.timeout_s,
                                             metadata=self.metadata)
        if path is not None:
            with open(path, "wb") as f:
                f.write(reply.model_file)
        return Model(reply.model_file)

    def history(self) -> History:
        """The session's plans and learning curve so far (:class:`History`)."""
        reply = self.client.stub.GetSessionHistory(
            pb.GetSessionHistoryRequest(name=self.name), timeout=self.client.timeout_s,
            metadata=self.metadata)
        return _common.history(reply, self.state_dim)

    def samples(self) -> Samples:
        """Every stored transition, in sequence order, as numpy arrays
        (:class:`Samples`: states, inputs, next_states, sequences, timestamps).
        Read with ExportSession, the one call that returns stored samples, so the
        message limit of :meth:`Client.export_session` applies."""
        return _common.samples(self.client.export_session(self.name))


class TransitionStream:
    """See :meth:`Session.stream`."""

    _END = object()

    def __init__(self, session: Session, batch_size: int, timeout_s: Optional[float]) -> None:
        self.session = session
        self.batch_size = batch_size
        self.timeout_s = timeout_s
        self.result: Optional[AddResult] = None  # the acknowledgements summed, once closed
        self.acknowledged = 0  # transitions acknowledged (stored, or already stored)
        self._pending: List[pb.Transition] = []
        # messages sent and not yet acknowledged
        self._sent: collections.deque[List[pb.Transition]] = collections.deque()
        self._queue: queue.Queue[Any] = queue.Queue()
        self._lock = threading.Lock()
        self._acked = threading.Condition(self._lock)  # an ack arrived, or the end
        self._stored = 0
        self._duplicates = 0
        self._first: Optional[int] = None
        self._last: Optional[int] = None
        self._last_ack: Optional[pb.AddDataAck] = None
        self._error: Optional[BaseException] = None
        self._call: Any = None
        self._reader: Optional[threading.Thread] = None
        self._reading = False

    def _requests(self) -> Iterator[pb.AddDataRequest]:
        first = True
        while True:
            item = self._queue.get()
            if item is self._END:
                return
            yield pb.AddDataRequest(session=self.session.name if first else "",
                                    transitions=item)
            first = False

    def _read_acks(self) -> None:
        try:
            for ack in self._call:
                with self._lock:
                    acked = self._sent.popleft()
                    self.acknowledged += len(acked)
                    self._stored += ack.stored
                    self._duplicates += ack.duplicates
                    self._last_ack = ack
                    sequences = [t.sequence for t in acked]
                    if sequences:
                        low, high = min(sequences), max(sequences)
                        self._first = low if self._first is None else min(self._first, low)
                        self._last = high if self._last is None else max(self._last, high)
                    self._acked.notify_all()
        except grpc.RpcError as error:
            self._error = converted(error)
        finally:
            with self._lock:
                self._reading = False
                self._acked.notify_all()

    def __enter__(self) -> TransitionStream:
        self._call = self.session.client.stub.StreamData(
            self._requests(), timeout=self.timeout_s, metadata=self.session.metadata)
        self._reading = True
        self._reader = threading.Thread(target=self._read_acks, daemon=True)
        self._reader.start()
        self.session._open_streams.append(self)
        return self

    def _forget(self) -> None:
        if self in self.session._open_streams:
            self.session._open_streams.remove(self)

    def flush(self, timeout_s: Optional[float] = None) -> None:
        """Sends what is pending and waits until the server has acknowledged (stored)
        every transition sent so far. Raises the stream's error, RuntimeError if the
        server ended the stream before acknowledging them, TimeoutError after
        `timeout_s` seconds (None: the stream's own deadline bounds the wait)."""
        with self._acked:
            self._flush()
            if not self._acked.wait_for(lambda: not self._sent or not self._reading,
                                        timeout=timeout_s):
                raise TimeoutError(f"{len(self._sent)} messages still unacknowledged after "
                                   f"{timeout_s} s")
        if self._error is not None:
            raise self._error
        if self._sent:
            raise RuntimeError(
                f"the server ended the stream with {len(self.unacknowledged())} "
                "transitions unacknowledged (not stored): resend stream.unacknowledged()")

    def _flush(self) -> None:  # with self._lock held
        if self._pending:
            self._sent.append(self._pending)
            self._queue.put(self._pending)
            self._pending = []

    def send(self, state: npt.ArrayLike, input: npt.ArrayLike, next_state: npt.ArrayLike,
             *, sequence: Optional[int] = None, timestamp: Optional[float] = None) -> None:
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

    def unacknowledged(self) -> List[pb.Transition]:
        """The transitions sent or queued but not acknowledged (resend these)."""
        with self._lock:
            return [t for message in self._sent for t in message] + list(self._pending)

    def close(self) -> AddResult:
        """Sends what is pending, waits for every acknowledgement, ends the stream and
        returns an :class:`AddResult` summing them. Raises the stream's error, or
        RuntimeError if the server ended it before acknowledging everything."""
        with self._lock:
            self._flush()
        self._queue.put(self._END)
        if self._reader is not None:
            self._reader.join()
        self._forget()
        if self._error is not None:
            raise self._error
        if self._sent:  # ended cleanly early: e.g. at a message it could not parse
            raise RuntimeError(
                f"the server ended the stream with {len(self.unacknowledged())} "
                "transitions unacknowledged (not stored): resend stream.unacknowledged()")
        last = self._last_ack
        self.result = AddResult(
            stored=self._stored, duplicates=self._duplicates,
            sample_count=last.sample_count if last else self.session.sample_count,
            model_version=last.model_version if last else self.session.model_version,
            first_sequence=self._first, last_sequence=self._last)
        self.session.sample_count = self.result.sample_count
        self.session.model_version = self.result.model_version
        return self.result

    def __exit__(self, exc_type: Optional[type], *rest: object) -> None:
        if exc_type is None:
            self.close()
        else:
            self._forget()
            self._call.cancel()
            self._queue.put(self._END)  # unblocks the request iterator


__all__ = ["Client", "Session", "TransitionStream", "AddResult", "Plan", "Prediction",
           "Samples", "session_config", "SESSION_HEADER"]
