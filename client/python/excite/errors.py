"""The exception the client raises for INVALID_ARGUMENT, with the server's field
violations (google.rpc.BadRequest in the grpc-status-details-bin trailer), and
the stub wrappers that raise it (blocking and asyncio)."""

from __future__ import annotations

from typing import Any, List, Tuple

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


class InvalidArgument(grpc.RpcError):
    """INVALID_ARGUMENT from the server: `violations` lists (field, description)
    for each problem of the request (e.g. ("config.noise.variance", "must be in
    [1e-30, 1e+30], got -1")). code(), details() and trailing_metadata() are the
    original error's."""

    def __init__(self, error: Any) -> None:
        super().__init__()
        self.error = error
        self.violations: List[Tuple[str, str]] = field_violations(error)

    def code(self) -> grpc.StatusCode:
        return self.error.code()

    def details(self) -> str:
        return self.error.details()

    def trailing_metadata(self) -> Any:
        return self.error.trailing_metadata()

    def __str__(self) -> str:
        lines = [f"INVALID_ARGUMENT: {self.details()}"]
        lines += [f"  {field}: {description}" for field, description in self.violations]
        return "\n".join(lines)


def converted(error: BaseException) -> BaseException:
    """`error`, as InvalidArgument if that is its code."""
    if isinstance(error, grpc.RpcError) and not isinstance(error, InvalidArgument) and \
            error.code() == grpc.StatusCode.INVALID_ARGUMENT:
        return InvalidArgument(error)
    return error


class CheckedStub:
    """The generated stub whose unary and client-streaming calls raise
    InvalidArgument for INVALID_ARGUMENT (other errors unchanged)."""

    def __init__(self, stub: Any) -> None:
        self._stub = stub

    def __getattr__(self, name: str) -> Any:
        return _CheckedMethod(getattr(self._stub, name))


class _CheckedMethod:
    def __init__(self, method: Any) -> None:
        self._method = method

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        try:
            return self._method(*args, **kwargs)
        except grpc.RpcError as error:
            raise converted(error) from None

    def __getattr__(self, name: str) -> Any:  # .future, .with_call: unchanged
        return getattr(self._method, name)


class AioCheckedStub:
    """The generated stub on a grpc.aio channel whose unary and client-streaming
    calls are coroutines raising InvalidArgument for INVALID_ARGUMENT."""

    def __init__(self, stub: Any) -> None:
        self._stub = stub

    def __getattr__(self, name: str) -> Any:
        method = getattr(self._stub, name)

        async def call(*args: Any, **kwargs: Any) -> Any:
            try:
                return await method(*args, **kwargs)
            except grpc.RpcError as error:
                raise converted(error) from None

        return call
