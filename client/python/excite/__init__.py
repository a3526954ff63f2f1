"""Python client of excite, the active-learning service for GP dynamics models.

    import excite
    with excite.Client("127.0.0.1:50051") as client:
        session = client.create_session("sim/configs/pendulum.textproto")
        plan = session.plan([0.0, 0.0])                   # excite.Plan
        result = session.add(states, inputs, next_states) # excite.AddResult
        prediction = session.predict(z)      # .mean, .variance: (n, state_dim)
        data = session.samples()             # excite.Samples: numpy arrays
        model = session.export_model("m.model")  # excite.Model: no server needed

``excite.aio`` has the same calls as coroutines (grpc.aio). The protobuf and gRPC
stubs are importable as ``excite.v1.exploration_service_pb2`` etc. (also
``excite.pb``, ``excite.config_pb``); they are generated from proto/ when the
package is built (``pip install client/python``), or, to use client/python in
place, by ``/usr/bin/python3 client/python/excite/codegen.py``. Importing never
generates anything. See client/python/README.md.
"""

from excite._common import (AddResult, History, Plan, Prediction, Rollout, Samples,
                            session_config)
from excite._pb import config_pb, pb
from excite.client import SESSION_HEADER, Client, Session, TransitionStream
from excite.model import Model, ModelFileError, ModelPrediction
from excite.errors import (Aborted, AlreadyExists, Cancelled, DataLoss, DeadlineExceeded,
                           ExciteError, FailedPrecondition, Internal, InvalidArgument,
                           NotFound, OutOfRange, PermissionDenied, ResourceExhausted,
                           Unauthenticated, Unavailable, Unimplemented, Unknown,
                           field_violations)

__version__ = "0.1.0"

__all__ = [
    "AddResult",
    "Client",
    "Model",
    "ModelFileError",
    "ModelPrediction",
    "ExciteError",
    "Aborted",
    "AlreadyExists",
    "Cancelled",
    "DataLoss",
    "DeadlineExceeded",
    "FailedPrecondition",
    "Internal",
    "InvalidArgument",
    "NotFound",
    "OutOfRange",
    "PermissionDenied",
    "ResourceExhausted",
    "Unauthenticated",
    "Unavailable",
    "Unimplemented",
    "Unknown",
    "field_violations",
    "History",
    "Plan",
    "Prediction",
    "Rollout",
    "Samples",
    "Session",
    "SESSION_HEADER",
    "TransitionStream",
    "session_config",
    "pb",
    "config_pb",
]
