"""Not a test module: code that mypy checks (ctest python_typecheck) to show that the
client's public API is typed: each annotation below must agree with what the API
declares, or the check fails. Never run."""

from __future__ import annotations

from typing import List, Optional

import numpy as np
import numpy.typing as npt

import excite
import excite.aio

FloatArray = npt.NDArray[np.float64]


def blocking(client: excite.Client, x: FloatArray, u: FloatArray, y: FloatArray) -> None:
    session: excite.Session = client.create_session({"state_dim": 2, "input_dim": 1})
    result: excite.AddResult = session.add(x, u, y, sequences=[0, 1])
    stored: int = result.stored + result.duplicates + result.sample_count
    first: Optional[int] = result.first_sequence
    plan: excite.Plan = session.plan([0.0, 0.0])
    to_apply: FloatArray = plan.to_apply
    status: str = plan.solver_status
    prediction: excite.Prediction = session.predict(states=x, inputs=u)
    mean: FloatArray = prediction.mean
    data: excite.Samples = session.samples()
    states: FloatArray = data.states
    sequences: npt.NDArray[np.int64] = data.sequences
    names: List[str] = [s.name for s in client.list_sessions()]
    with session.stream() as stream:
        stream.send(x[0], u[0], y[0])
    closed: Optional[excite.AddResult] = stream.result
    archive: excite.pb.SessionArchive = client.export_session(session.name)
    config: excite.config_pb.SessionConfig = excite.session_config(archive.config)
    del stored, first, to_apply, status, mean, states, sequences, names, closed, config


async def asynchronous(x: FloatArray, u: FloatArray, y: FloatArray) -> None:
    async with excite.aio.Client("127.0.0.1:50051") as client:
        session: excite.aio.Session = await client.create_session("config.textproto")
        result: excite.AddResult = await session.add(x, u, y)
        plan: excite.Plan = await session.plan([0.0, 0.0])
        prediction: excite.Prediction = await session.predict(np.hstack([x, u]))
        data: excite.Samples = await session.samples()
        ids: List[str] = [s.id async for s in client.list_sessions()]
        await session.delete()
        del result, plan, prediction, data, ids
