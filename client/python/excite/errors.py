"""The exceptions the client raises, one per gRPC status (InvalidArgument with
the server's field violations, google.rpc.BadRequest in the
grpc-status-details-bin trailer), and the stub wrappers that raise them and
resend after UNAVAILABLE (blocking and asyncio)."""

from __future__ import annotations

import asyncio
import time
from typing import Any, List, Optional, Tuple

import grpc
from google.protobuf import descriptor_pb2, descriptor_pool, message_factory


def _rpc_messages() -> Tuple[Any, Any]:
    """google.rpc.Status and google.rpc.BadRequest, built from their wire layout
    (Debian ships no Python googleapis-common-protos): the server's bytes parse
    with them exactly."""
    file = descriptor_pb2.FileDescriptorProto(
        name="excite/google_rpc_details.proto", package="google.rpc", syntax="proto3")
    f = descriptor_pb2.FieldDescriptorProto
    status = file.message_type.add(name="Status")
    status.field.add(name="code", number=1, type=f.TYPE_INT32, label=f.LABEL_OPTIONAL)
    status.field.add(name="message", number=2, type=f.TYPE_STRING, label=f.LABEL_OPTIONAL)
    any_ = file.message_type.add(name="AnyDetail")  # google.protobuf.Any's layout
    any_.field.add(name="type_url", number=1, type=f.TYPE_STRING, label=f.LABEL_OPTIONAL)
    any_.field.add(name="value", number=2, type=f.TYPE_BYTES, label=f.LABEL_OPTIONAL)
    status.field.add(name="details", number=3, type=f.TYPE_MESSAGE,
                     type_name=".google.rpc.AnyDetail", label=f.LABEL_REPEATED)
    bad = file.message_type.add(name="BadRequest")
    violation = bad.nested_type.add(name="FieldViolation")
    violation.field.add(name="field", number=1, type=f.TYPE_STRING, label=f.LABEL_OPTIONAL)
    violation.field.add(name="description", number=2, type=f.TYPE_STRING,
                        label=f.LABEL_OPTIONAL)
    bad.field.add(name="field_violations", number=1, type=f.TYPE_MESSAGE,
                  type_name=".google.rpc.BadRequest.FieldViolation",
                  label=f.LABEL_REPEATED)
    pool = descriptor_pool.DescriptorPool()
    pool.Add(file)
    factory = message_factory.MessageFactory(pool)
    return (factory.GetPrototype(pool.FindMessageTypeByName("google.rpc.Status")),
            factory.GetPrototype(pool.FindMessageTypeByName("google.rpc.BadRequest")))


_Status, _BadRequest = _rpc_messages()


def field_violations(error: Any) -> List[Tuple[str, str]]:
    """[(field, description), ...] from an RpcError's google.rpc.BadRequest details;
    [] if it carries none."""
    trailers = error.trailing_metadata() if hasattr(error, "trailing_metadata") else None
    for key, value in trailers or ():
        if key != "grpc-status-details-bin":
            continue
        status = _Status.FromString(value)
        for detail in status.details:
            if detail.type_url.endswith("/google.rpc.BadRequest"):
                bad = _BadRequest.FromString(detail.value)
                return [(v.field, v.description) for v in bad.field_violations]
    return []


class ExciteError(grpc.RpcError):
    """An error of the server (or of reaching it), as a typed exception: one
    subclass per gRPC status (NotFound, FailedPrecondition, Unavailable, ...), each
    still a ``grpc.RpcError`` whose code(), details() and trailing_metadata() are
    the original error's. str() is "CODE: message"."""

    def __init__(self, error: Any) -> None:
        super().__init__()
        self.error = error

    def code(self) -> grpc.StatusCode:
        return self.error.code()

    def details(self) -> str:
        return self.error.details()

    def trailing_metadata(self) -> Any:
        return self.error.trailing_metadata()

    def __str__(self) -> str:
        return f"{self.code().name}: {self.details()}"


class InvalidArgument(ExciteError):
    """INVALID_ARGUMENT from the server: `violations` lists (field, description)
    for each problem of the request (e.g. ("config.noise.variance", "must be in
    [1e-30, 1e+30], got -1"))."""

    def __init__(self, error: Any) -> None:
        super().__init__(error)
        self.violations: List[Tuple[str, str]] = field_violations(error)

    def __str__(self) -> str:
        lines = [f"INVALID_ARGUMENT: {self.details()}"]
        lines += [f"  {field}: {description}" for field, description in self.violations]
        return "\n".join(lines)


class Cancelled(ExciteError):
    """CANCELLED: the call was cancelled (by this client)."""


class Unknown(ExciteError):
    """UNKNOWN: e.g. the stream to a replica that died was dropped mid-call."""


class DeadlineExceeded(ExciteError):
    """DEADLINE_EXCEEDED: no answer in time (timeout_s / plan_timeout_s)."""


class NotFound(ExciteError):
    """NOT_FOUND: no such session."""


class AlreadyExists(ExciteError):
    """ALREADY_EXISTS: a session with that id exists."""


class PermissionDenied(ExciteError):
    """PERMISSION_DENIED."""


class ResourceExhausted(ExciteError):
    """RESOURCE_EXHAUSTED: a cap (samples per session, memory budget, sessions)."""


class FailedPrecondition(ExciteError):
    """FAILED_PRECONDITION: e.g. too few samples to predict or plan yet."""


class Aborted(ExciteError):
    """ABORTED: e.g. the session moved to another replica; retry."""


class OutOfRange(ExciteError):
    """OUT_OF_RANGE."""


class Unimplemented(ExciteError):
    """UNIMPLEMENTED."""


class Internal(ExciteError):
    """INTERNAL: a fault of the server (report it)."""


class Unavailable(ExciteError):
    """UNAVAILABLE: the server cannot be reached (or is shutting down)."""


class DataLoss(ExciteError):
    """DATA_LOSS: stored data of the session cannot be read."""


class Unauthenticated(ExciteError):
    """UNAUTHENTICATED: no or a wrong auth token."""


_BY_CODE = {
    grpc.StatusCode.CANCELLED: Cancelled,
    grpc.StatusCode.UNKNOWN: Unknown,
    grpc.StatusCode.INVALID_ARGUMENT: InvalidArgument,
    grpc.StatusCode.DEADLINE_EXCEEDED: DeadlineExceeded,
    grpc.StatusCode.NOT_FOUND: NotFound,
    grpc.StatusCode.ALREADY_EXISTS: AlreadyExists,
    grpc.StatusCode.PERMISSION_DENIED: PermissionDenied,
    grpc.StatusCode.RESOURCE_EXHAUSTED: ResourceExhausted,
    grpc.StatusCode.FAILED_PRECONDITION: FailedPrecondition,
    grpc.StatusCode.ABORTED: Aborted,
    grpc.StatusCode.OUT_OF_RANGE: OutOfRange,
    grpc.StatusCode.UNIMPLEMENTED: Unimplemented,
    grpc.StatusCode.INTERNAL: Internal,
    grpc.StatusCode.UNAVAILABLE: Unavailable,
    grpc.StatusCode.DATA_LOSS: DataLoss,
    grpc.StatusCode.UNAUTHENTICATED: Unauthenticated,
}


def converted(error: BaseException) -> BaseException:
    """`error` as the ExciteError subclass of its status code (unchanged if it is
    one already or not an RpcError)."""
    if isinstance(error, grpc.RpcError) and not isinstance(error, ExciteError):
        kind = _BY_CODE.get(error.code())
        if kind is not None:
            return kind(error)
    return error


# When a call may be sent again, as the C++ client's Resend: reads and PlanInputs
# also after a lost answer (UNKNOWN "Stream removed": a replica died mid-call),
# AddData also after a deadline (sequence numbers make a resent batch a
# duplicate); calls that could do their work twice only after UNAVAILABLE.
_AFTER_LOST_ANSWER = {"GetSession", "ListSessions", "Predict", "ExportSession",
                      "PlanInputs"}
_AFTER_DEADLINE_TOO = {"AddData"}


def _may_resend(method: str, error: Any) -> bool:
    code = error.code() if isinstance(error, grpc.RpcError) else None
    if code == grpc.StatusCode.UNAVAILABLE:
        return True
    lost = code == grpc.StatusCode.UNKNOWN and "Stream removed" in (error.details() or "")
    if lost and (method in _AFTER_LOST_ANSWER or method in _AFTER_DEADLINE_TOO):
        return True
    return code == grpc.StatusCode.DEADLINE_EXCEEDED and method in _AFTER_DEADLINE_TOO


class _Backoff:
    """0.1 s doubling to 2 s, within `window_s` from the first try."""

    def __init__(self, window_s: float) -> None:
        self.end = time.monotonic() + window_s
        self.delay = 0.1

    def next_delay(self) -> Optional[float]:
        left = self.end - time.monotonic()
        if left <= 0:
            return None
        delay = min(self.delay, left)
        self.delay = min(2.0 * self.delay, 2.0)
        return delay


class CheckedStub:
    """The generated stub whose unary and client-streaming calls raise
    ExciteError subclasses, and resend after UNAVAILABLE (and what _may_resend
    allows) within `retry_unavailable_s` seconds."""

    def __init__(self, stub: Any, retry_unavailable_s: float = 0.0) -> None:
        self._stub = stub
        self._retry_s = retry_unavailable_s

    def __getattr__(self, name: str) -> Any:
        return _CheckedMethod(getattr(self._stub, name), name, self._retry_s)


class _CheckedMethod:
    def __init__(self, method: Any, name: str, retry_s: float) -> None:
        self._method = method
        self._name = name
        self._retry_s = retry_s

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        backoff = _Backoff(self._retry_s)
        while True:
            try:
                return self._method(*args, **kwargs)
            except grpc.RpcError as error:
                delay = backoff.next_delay() if _may_resend(self._name, error) else None
                if delay is None:
                    raise converted(error) from None
                time.sleep(delay)

    def __getattr__(self, name: str) -> Any:  # .future, .with_call: unchanged
        return getattr(self._method, name)


class AioCheckedStub:
    """The generated stub on a grpc.aio channel whose unary and client-streaming
    calls are coroutines raising ExciteError subclasses, resent as CheckedStub's."""

    def __init__(self, stub: Any, retry_unavailable_s: float = 0.0) -> None:
        self._stub = stub
        self._retry_s = retry_unavailable_s

    def __getattr__(self, name: str) -> Any:
        method = getattr(self._stub, name)
        retry_s = self._retry_s

        async def call(*args: Any, **kwargs: Any) -> Any:
            backoff = _Backoff(retry_s)
            while True:
                try:
                    return await method(*args, **kwargs)
                except grpc.RpcError as error:
                    delay = backoff.next_delay() if _may_resend(name, error) else None
                    if delay is None:
                        raise converted(error) from None
                    await asyncio.sleep(delay)

        return call
