"""Python client of excite, the active-learning service for GP dynamics models.

    import excite
    with excite.Client("127.0.0.1:50051") as client:
        session = client.create_session("sim/configs/pendulum.textproto")
        plan = session.plan([0.0, 0.0])
        session.add(states, inputs, next_states)
        prediction = session.predict(z)      # .mean, .variance: (n, state_dim)

The protobuf and gRPC stubs are generated from proto/ on first import (and again
whenever the protos change) with Debian's protoc and grpc_python_plugin; they are
importable as ``excite.v1.exploration_service_pb2`` etc. See client/python/README.md.
"""

from excite import codegen as _codegen

_codegen.ensure_stubs()

from excite.client import (  # noqa: E402  (the stubs must exist first)
    Client,
    Plan,
    Prediction,
    Session,
    TransitionStream,
    session_config,
)
from excite.errors import InvalidArgument, field_violations  # noqa: E402
from excite.v1 import exploration_service_pb2 as pb  # noqa: E402
from excite.v1 import session_config_pb2 as config_pb  # noqa: E402

__all__ = [
    "Client",
    "InvalidArgument",
    "field_violations",
    "Plan",
    "Prediction",
    "Session",
    "TransitionStream",
    "session_config",
    "pb",
    "config_pb",
]
