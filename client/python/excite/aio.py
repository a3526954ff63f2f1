"""The asyncio client, on grpc.aio: the blocking client's main calls as coroutines.

    import asyncio
    import excite.aio

    async def main():
        async with excite.aio.Client("127.0.0.1:50051") as client:
            session = await client.create_session("sim/configs/pendulum.textproto")
            result = await session.add(states, inputs, next_states)   # AddResult
            plan = await session.plan([0.0, 0.0])                      # Plan
            prediction = await session.predict(z)                      # Prediction
            data = await session.samples()                             # Samples
            await session.delete()

    asyncio.run(main())

Arguments, results and errors are those of :mod:`excite.client` (the conversions are
shared, in excite._common): INVALID_ARGUMENT is :class:`excite.InvalidArgument`,
other errors ``grpc.aio.AioRpcError`` (a ``grpc.RpcError``). Create the client
inside the event loop that uses it. Not here: StreamData (``Session.stream``); the
raw generated stub is ``Client.stub``.
"""

from __future__ import annotations

import asyncio
import os
from typing import Any, AsyncIterator, List, Mapping, Optional, Union

import grpc
import grpc.aio
import numpy.typing as npt

from excite import _common
from excite._common import (AddResult, ArchiveLike, ConfigLike, History, Plan, Prediction,
                            Rollout, Samples)
from excite._pb import config_pb, pb, pb_grpc
from excite.errors import AioCheckedStub
from excite.model import Model

PathLike = Union[str, "os.PathLike[str]"]


class _WithToken:
    """Adds "authorization: Bearer <token>" to the call's metadata."""

    def __init__(self, token: str) -> None:
        self._header = _common.auth_header(token)

    def _with_token(self, details: Any) -> grpc.aio.ClientCallDetails:
        metadata = grpc.aio.Metadata(*(details.metadata or ()))
        metadata.add(*self._header)
        return grpc.aio.ClientCallDetails(details.method, details.timeout, metadata,
                                          details.credentials, details.wait_for_ready)


# grpc.aio files an interceptor under one kind of call only: one class per kind.
class _UnaryToken(_WithToken, grpc.aio.UnaryUnaryClientInterceptor):
    async def intercept_unary_unary(self, continuation: Any, details: Any,
                                    request: Any) -> Any:
        return await continuation(self._with_token(details), request)


class _StreamUnaryToken(_WithToken, grpc.aio.StreamUnaryClientInterceptor):
    async def intercept_stream_unary(self, continuation: Any, details: Any,
                                     request_iterator: Any) -> Any:
        return await continuation(self._with_token(details), request_iterator)


def _token_interceptors(token: str) -> Optional[List[Any]]:
    """Unary and client-streaming calls (all that this client makes) send the token."""
    return [_UnaryToken(token), _StreamUnaryToken(token)] if token else None


class Client:
    """An asyncio connection to excite-server; ``async with`` or ``await close()``.
    Settings as :class:`excite.Client`."""

    def __init__(self, target: str = "127.0.0.1:50051", *, timeout_s: float = 30.0,
                 plan_timeout_s: float = 60.0, max_message_mb: int = 64,
                 tls_ca: Optional[PathLike] = None,
                 tls_client_cert: Optional[PathLike] = None,
                 tls_client_key: Optional[PathLike] = None,
                 auth_token: Optional[str] = None,
                 retry_unavailable_s: float = 0.0) -> None:
        """As excite.Client's."""
        self.target = target
        options = _common.channel_options(max_message_mb)
        credentials = _common.channel_credentials(tls_ca, tls_client_cert, tls_client_key)
        token = _common.auth_token(auth_token)
        interceptors = _token_interceptors(token)
        self.channel: grpc.aio.Channel = (
            grpc.aio.insecure_channel(target, options=options, interceptors=interceptors)
            if credentials is None else
            grpc.aio.secure_channel(target, credentials, options=options,
                                    interceptors=interceptors))
        self.stub: Any = pb_grpc.ExplorationServiceStub(self.channel)
        self._calls: Any = AioCheckedStub(self.stub, retry_unavailable_s)
        self.timeout_s = timeout_s
        self.plan_timeout_s = plan_timeout_s
        self._health_check = self.channel.unary_unary(_common.HEALTH_CHECK_METHOD)

    async def close(self) -> None:
        await self.channel.close()

    async def __aenter__(self) -> Client:
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.close()

    async def wait_for_ready(self, timeout_s: float = 10.0) -> None:
        """Waits until the channel is connected; ``asyncio.TimeoutError`` if not within
        `timeout_s`."""
        await asyncio.wait_for(self.channel.channel_ready(), timeout_s)

    async def health(self, service: str = "") -> str:
        """The grpc.health.v1 status name ("SERVING", "NOT_SERVING", ...)."""
        reply = await self._health_check(_common.health_request(service),
                                         timeout=self.timeout_s)
        return _common.health_status(reply)

    async def create_session(self, config: ConfigLike, session_id: str = "",
                             display_name: str = "",
                             labels: Optional[Mapping[str, str]] = None) -> Session:
        """Creates a session (see :func:`excite.session_config`); returns it."""
        request = pb.CreateSessionRequest(session_id=session_id,
                                          config=_common.session_config(config),
                                          display_name=display_name, labels=labels or {})
        info = await self._calls.CreateSession(
            request, timeout=self.timeout_s, metadata=_common.session_metadata(session_id))
        return Session(self, info)

    async def session(self, name: str) -> Session:
        """The session "sessions/{id}" (or "{id}"); NOT_FOUND if there is none."""
        info = await self._calls.GetSession(
            pb.GetSessionRequest(name=_common.full_name(name)), timeout=self.timeout_s,
            metadata=_common.session_metadata(name))
        return Session(self, info)

    async def list_sessions(self, page_size: int = 0,
                            filter: str = "") -> AsyncIterator[Session]:
        """``async for`` over every session whose labels match `filter`, fetching
        pages of `page_size`."""
        token = ""
        while True:
            page = await self._calls.ListSessions(
                pb.ListSessionsRequest(page_size=page_size, page_token=token, filter=filter),
                timeout=self.timeout_s)
            for info in page.sessions:
                yield Session(self, info)
            token = page.next_page_token
            if not token:
                return

    async def delete_session(self, name: str) -> None:
        await self._calls.DeleteSession(
            pb.DeleteSessionRequest(name=_common.full_name(name)), timeout=self.timeout_s,
            metadata=_common.session_metadata(name))

    async def export_session(self, name: str) -> pb.SessionArchive:
        """The session as a ``SessionArchive`` (see :meth:`excite.Client.export_session`)."""
        archive: pb.SessionArchive = await self._calls.ExportSession(
            pb.ExportSessionRequest(name=_common.full_name(name)), timeout=self.timeout_s,
            metadata=_common.session_metadata(name))
        return archive

    async def import_session(self, archive: ArchiveLike,
                             session_id: Optional[str] = None) -> Session:
        """Creates a session from an archive (see :meth:`excite.Client.import_session`)."""
        message = _common.session_archive(archive)
        info = await self._calls.ImportSession(
            pb.ImportSessionRequest(archive=message, session_id=session_id or ""),
            timeout=self.timeout_s,
            metadata=_common.session_metadata(session_id or message.session_id))
        return Session(self, info)


class Session(_common.SessionView):
    """One session, as :class:`excite.Session` with coroutine methods."""

    client: Client

    def __init__(self, client: Client, info: pb.Session) -> None:
        self.client = client
        self._set(info)

    def __repr__(self) -> str:
        return (f"aio.Session({self.name!r}, state_dim={self.state_dim}, "
                f"input_dim={self.input_dim}, samples={self.sample_count})")

    async def refresh(self) -> Session:
        self._set(await self.client._calls.GetSession(
            pb.GetSessionRequest(name=self.name), timeout=self.client.timeout_s,
            metadata=self.metadata))
        return self

    async def delete(self) -> None:
        await self.client.delete_session(self.name)

    async def add(self, states: npt.ArrayLike, inputs: npt.ArrayLike,
                  next_states: npt.ArrayLike, *, sequences: Optional[npt.ArrayLike] = None,
                  timestamps: Optional[npt.ArrayLike] = None,
                  batch_size: int = 256) -> AddResult:
        """One AddData stream (see :meth:`excite.Session.add`)."""
        items: List[pb.Transition]
        items, self.next_sequence = _common.transitions(
            self.state_dim, self.input_dim, self.next_sequence, states, inputs,
            next_states, sequences, timestamps)
        requests = _common.add_requests(self.name, items, batch_size)
        reply = await self.client._calls.AddData(
            iter(requests), timeout=self.client.timeout_s, metadata=self.metadata)
        result = _common.add_result(reply, items)
        self.sample_count = result.sample_count
        self.model_version = result.model_version
        return result

    async def predict(self, z: Optional[npt.ArrayLike] = None, *,
                      states: Optional[npt.ArrayLike] = None,
                      inputs: Optional[npt.ArrayLike] = None,
                      include_noise: bool = False) -> Prediction:
        """See :meth:`excite.Session.predict`."""
        request, n = _common.predict_request(self.name, self.state_dim, self.input_dim,
                                             z, states, inputs, include_noise)
        reply = await self.client._calls.Predict(request, timeout=self.client.timeout_s,
                                                 metadata=self.metadata)
        return _common.prediction(reply, n, self.state_dim)

    async def plan(self, state: npt.ArrayLike,
                   pending_inputs: Optional[npt.ArrayLike] = None) -> Plan:
        """See :meth:`excite.Session.plan`."""
        request = _common.plan_request(self.name, self.state_dim, self.input_dim, state,
                                       pending_inputs)
        reply = await self.client._calls.PlanInputs(
            request, timeout=self.client.plan_timeout_s, metadata=self.metadata)
        return _common.plan(reply, self.state_dim, self.input_dim)

    async def rollout(self, state: npt.ArrayLike, inputs: npt.ArrayLike, *,
                      state_variance: Optional[npt.ArrayLike] = None,
                      include_noise: bool = False) -> Rollout:
        """The model rolled forward (see :meth:`excite.Session.rollout`)."""
        request = _common.rollout_request(self.name, self.state_dim, self.input_dim, state,
                                          inputs, state_variance, include_noise)
        reply = await self.client._calls.Rollout(request, timeout=self.client.timeout_s,
                                                 metadata=self.metadata)
        return _common.rollout(reply, self.state_dim)

    async def export_model(self, path: Optional[PathLike] = None) -> Model:
        """The fitted model, to predict without a server (see
        :meth:`excite.Session.export_model`)."""
        reply = await self.client._calls.ExportModel(
            pb.ExportModelRequest(name=self.name), timeout=self.client.timeout_s,
            metadata=self.metadata)
        if path is not None:
            with open(path, "wb") as f:
                f.write(reply.model_file)
        return Model(reply.model_file)

    async def history(self) -> History:
        """The plans and learning curve so far (see :meth:`excite.Session.history`)."""
        reply = await self.client._calls.GetSessionHistory(
            pb.GetSessionHistoryRequest(name=self.name), timeout=self.client.timeout_s,
            metadata=self.metadata)
        return _common.history(reply, self.state_dim)

    async def samples(self) -> Samples:
        """Every stored transition as arrays (see :meth:`excite.Session.samples`)."""
        return _common.samples(await self.client.export_session(self.name))


__all__ = ["Client", "Session", "AddResult", "History", "Plan", "Prediction", "Rollout",
           "Samples"]
