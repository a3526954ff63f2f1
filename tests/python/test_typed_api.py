"""The typed results (AddResult, Samples) and the asyncio client (excite.aio)
against a real excite-server."""

import asyncio
import dataclasses

import grpc
import numpy as np
import pytest

import excite
import excite.aio
from test_client import linear_config, linear_data


def test_add_returns_a_typed_result(client):
    session = client.create_session(linear_config())
    x, u, x_next, _, _ = linear_data(7, seed=11)
    result = session.add(x, u, x_next, batch_size=3)
    assert isinstance(result, excite.AddResult)
    assert result == excite.AddResult(stored=7, duplicates=0, sample_count=7,
                                      model_version=result.model_version,
                                      first_sequence=0, last_sequence=6)
    assert result.sent == 7
    with pytest.raises(dataclasses.FrozenInstanceError):
        result.stored = 0  # type: ignore[misc]

    retry = session.add(x[2:4], u[2:4], x_next[2:4], sequences=[2, 3])
    assert (retry.stored, retry.duplicates, retry.sample_count) == (0, 2, 7)
    assert (retry.first_sequence, retry.last_sequence) == (2, 3)
    more = session.add(x[0], u[0], x_next[0])  # one 1-D transition, numbered 7
    assert (more.stored, more.first_sequence, more.last_sequence) == (1, 7, 7)
    assert session.sample_count == 8
    empty = session.add(np.zeros((0, 2)), np.zeros((0, 1)), np.zeros((0, 2)))
    assert (empty.stored, empty.sent, empty.first_sequence, empty.last_sequence) == (
        0, 0, None, None)

    with session.stream(batch_size=2) as stream:
        for i in range(3):
            stream.send(x[i], u[i], x_next[i])
    assert stream.result == excite.AddResult(
        stored=3, duplicates=0, sample_count=11, model_version=stream.result.model_version,
        first_sequence=8, last_sequence=10)
    session.delete()


def test_samples_round_trip_exactly(client):
    session = client.create_session(linear_config())
    empty = session.samples()
    assert len(empty) == 0
    assert empty.states.shape == (0, 2) and empty.inputs.shape == (0, 1)
    assert empty.next_states.shape == (0, 2) and empty.sequences.shape == (0,)

    x, u, x_next, _, _ = linear_data(9, seed=12)
    x[0, 0] = 1.0 / 3.0  # not a short decimal: the doubles must come back bit for bit
    x[1, 1] = -5e-324   # the smallest subnormal
    sequences = np.array([40, 3, 17, 5, 6, 7, 100, 8, 9])
    timestamps = 1.7e9 + np.arange(9) * 0.125
    session.add(x, u, x_next, sequences=sequences, timestamps=timestamps)

    data = session.samples()
    assert isinstance(data, excite.Samples) and len(data) == 9
    order = np.argsort(sequences)  # stored in sequence order
    np.testing.assert_array_equal(data.sequences, sequences[order])
    assert data.sequences.dtype == np.int64 and data.states.dtype == np.float64
    assert data.states.tobytes() == x[order].tobytes()
    assert data.inputs.tobytes() == u[order].tobytes()
    assert data.next_states.tobytes() == x_next[order].tobytes()
    np.testing.assert_array_equal(data.timestamps, timestamps[order])
    session.delete()


def test_asyncio_client_add_plan_predict_samples(server):
    async def run():
        async with excite.aio.Client(server.address, timeout_s=30) as client:
            await client.wait_for_ready(10)
            assert await client.health() == "SERVING"
            session = await client.create_session(linear_config(horizon=4),
                                                  session_id="py-aio")
            assert isinstance(session, excite.aio.Session)
            assert (session.name, session.state_dim, session.input_dim) == (
                "sessions/py-aio", 2, 1)
            with pytest.raises(grpc.RpcError) as error:  # no data yet
                await session.plan([0.0, 0.0])
            assert error.value.code() == grpc.StatusCode.FAILED_PRECONDITION

            x, u, x_next, _, _ = linear_data(20, seed=13)
            added = await session.add(x, u, x_next, batch_size=8)
            assert added == excite.AddResult(stored=20, duplicates=0, sample_count=20,
                                             model_version=added.model_version,
                                             first_sequence=0, last_sequence=19)
            again = await session.add(x[:2], u[:2], x_next[:2], sequences=[0, 1])
            assert (again.stored, again.duplicates) == (0, 2)

            # Two calls in flight at once on one channel.
            plan, prediction = await asyncio.gather(
                session.plan([0.2, -0.1]), session.predict(np.hstack([x[:5], u[:5]])))
            assert isinstance(plan, excite.Plan) and plan.inputs.shape == (4, 1)
            assert np.all(np.abs(plan.inputs) <= 1.0 + 1e-9)
            np.testing.assert_allclose(plan.predicted_states[0], [0.2, -0.1])
            assert plan.to_apply.shape == (1, 1)
            assert isinstance(prediction, excite.Prediction)
            assert prediction.mean.shape == (5, 2) and np.all(prediction.variance > 0)
            np.testing.assert_allclose(prediction.mean, x_next[:5], atol=0.05)

            data = await session.samples()
            assert data.states.tobytes() == x.tobytes()
            np.testing.assert_array_equal(data.sequences, np.arange(20))

            fetched = await client.session("py-aio")
            assert fetched.sample_count == 20 and fetched.last_sequence == 19
            assert [s.id async for s in client.list_sessions(page_size=1)] == ["py-aio"]
            archive = await client.export_session("py-aio")
            copy = await client.import_session(archive, session_id="py-aio-copy")
            assert copy.sample_count == 20

            bad = excite.session_config(linear_config())
            bad.noise.variance = -1
            with pytest.raises(excite.InvalidArgument) as invalid:
                await client.create_session(bad)
            assert [f for f, _ in invalid.value.violations] == ["config.noise.variance"]

            await copy.delete()
            await session.delete()
            with pytest.raises(grpc.RpcError) as error:
                await session.refresh()
            assert error.value.code() == grpc.StatusCode.NOT_FOUND

    asyncio.run(asyncio.wait_for(run(), 60))


def test_clients_send_the_bearer_token_on_every_kind_of_call(tmp_path):
    """A plaintext server with --auth_token_file: the aio client's calls carry the
    bearer token (refused without it), and so does the blocking client's StreamData."""
    from conftest import ServerProcess

    (tmp_path / "token").write_text("aio-token\n")
    server = ServerProcess(tmp_path / "data",
                           [f"--auth_token_file={tmp_path / 'token'}"]).start()

    async def run():
        async with excite.aio.Client(server.address, auth_token="aio-token") as client:
            session = await client.create_session(linear_config(), session_id="tok")
            added = await session.add(*linear_data(3, 1)[:3])
            assert added.stored == 3 and session.metadata == (("x-excite-session", "tok"),)
        async with excite.aio.Client(server.address, auth_token="") as client:
            with pytest.raises(grpc.RpcError) as error:
                await client.session("tok")
            assert error.value.code() == grpc.StatusCode.UNAUTHENTICATED

    try:
        asyncio.run(asyncio.wait_for(run(), 60))
        with excite.Client(server.address, auth_token="aio-token") as client:
            session = client.session("tok")
            x, u, x_next, _, _ = linear_data(2, 2)
            with session.stream() as stream:  # a bidirectional stream
                stream.send(x[0], u[0], x_next[0])
            assert stream.result is not None and stream.result.sample_count == 4
    finally:
        assert server.stop() == 0


def test_display_name_labels_and_filter(client, server):
    import datetime
    before = datetime.datetime.now(datetime.timezone.utc).replace(microsecond=0)
    a = client.create_session(linear_config(), session_id="lab-a", display_name="Rig A",
                              labels={"plant": "linear", "rig": "a"})
    client.create_session(linear_config(), session_id="lab-b", labels={"plant": "linear"})
    client.create_session(linear_config(), session_id="lab-c", labels={"plant": "other"})
    assert (a.display_name, a.labels) == ("Rig A", {"plant": "linear", "rig": "a"})
    assert a.create_time is not None and a.create_time >= before
    assert a.create_time <= datetime.datetime.now(datetime.timezone.utc)
    ids = [s.id for s in client.list_sessions(filter='labels.plant = "linear"')]
    assert ids == ["lab-a", "lab-b"]
    assert [s.id for s in client.list_sessions(page_size=1, filter="labels.rig:*")] == ["lab-a"]
    with pytest.raises(excite.InvalidArgument) as error:
        client.create_session(linear_config(), labels={"Bad Key": "x"})
    assert [field for field, _ in error.value.violations] == ['labels["Bad Key"]']
    with pytest.raises(excite.InvalidArgument) as error:
        list(client.list_sessions(filter="plant = linear"))
    assert "only labels can be filtered on" in str(error.value.details())

    async def run():
        async with excite.aio.Client(server.address, timeout_s=30) as aio_client:
            made = await aio_client.create_session(linear_config(), session_id="lab-d",
                                                   display_name="D", labels={"plant": "other"})
            assert (made.display_name, made.labels) == ("D", {"plant": "other"})
            return [s.id async for s in aio_client.list_sessions(filter="labels.plant = other")]
    assert asyncio.run(run()) == ["lab-c", "lab-d"]
    for name in ("lab-a", "lab-b", "lab-c", "lab-d"):
        client.delete_session(name)
