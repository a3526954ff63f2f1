"""The Python client (client/python) against a real excite-server process."""

import os
import pathlib
import re
import socket
import subprocess
import sys
import threading
import time

import grpc
import numpy as np
import pytest

import excite
from conftest import REPO, ServerProcess

PENDULUM = REPO / "sim" / "configs" / "pendulum.textproto"

# A linear plant x_{k+1} = A x_k + B u_k for tests that need a learnable model.
A = np.array([[1.0, 0.1], [-0.1, 0.95]])
B = np.array([[0.0], [0.1]])
NOISE = 1e-4


def linear_config(**overrides):
    config = {
        "state_dim": 2,
        "input_dim": 1,
        "input_bounds": [[-1.0, 1.0]],
        "state_bounds": [[-1.0, 1.0], [-1.0, 1.0]],
        "noise": {"variance": NOISE, "fit": True},
        "kernel": {"fit": True},
        "target": "delta",
        "strategy": "rec",
        "horizon": 5,
        "seed": 3,
    }
    config.update(overrides)
    return config


def linear_data(n, seed):
    rng = np.random.default_rng(seed)
    x = rng.uniform(-1, 1, size=(n, 2))
    u = rng.uniform(-1, 1, size=(n, 1))
    x_next = x @ A.T + u @ B.T
    noise = lambda: rng.normal(0, np.sqrt(NOISE), size=(n, 2))  # noqa: E731
    return x + noise(), u, x_next + noise(), x, x_next


def test_health_is_serving(client):
    assert client.health() == "SERVING"


def test_session_lifecycle(client):
    created = client.create_session(linear_config(), session_id="py-life")
    assert created.name == "sessions/py-life"
    assert (created.state_dim, created.input_dim) == (2, 1)
    assert created.sample_count == 0 and created.last_sequence == -1
    assert created.config.strategy == excite.config_pb.STRATEGY_REC
    assert created.config.target == excite.config_pb.TARGET_DELTA
    bounds = created.config.input_bounds[0]
    assert (bounds.lower, bounds.upper) == (-1.0, 1.0)

    fetched = client.session("py-life")
    assert fetched.config == created.config

    client.create_session(linear_config(), session_id="py-life-2")
    names = [s.name for s in client.list_sessions(page_size=1)]  # pages of one
    assert {"sessions/py-life", "sessions/py-life-2"} <= set(names)
    assert len(names) == len(set(names))

    with pytest.raises(excite.AlreadyExists) as error:  # typed, still an RpcError
        client.create_session(linear_config(), session_id="py-life")
    assert error.value.code() == grpc.StatusCode.ALREADY_EXISTS
    assert isinstance(error.value, grpc.RpcError)
    assert isinstance(error.value, excite.ExciteError)
    assert str(error.value).startswith("ALREADY_EXISTS: ")

    created.delete()
    client.delete_session("sessions/py-life-2")
    with pytest.raises(excite.NotFound) as error:
        client.session("py-life")
    assert error.value.code() == grpc.StatusCode.NOT_FOUND
    assert "py-life" in str(error.value)


def test_config_from_textproto_file_string_and_errors(client):
    from_file = client.create_session(PENDULUM)  # a SimConfig file: its session
    assert from_file.config.horizon == 15
    assert from_file.config.noise.variance == pytest.approx(0.05)
    assert re.fullmatch(r"sessions/[a-z0-9-]+", from_file.name)
    from_file.delete()

    text = """
        state_dim: 1 input_dim: 1
        input_bounds { lower: -2 upper: 2 }
        noise { variance: 0.01 }
        kernel { fit: true }
        strategy: STRATEGY_PA horizon: 4
    """
    from_text = client.create_session(text)
    assert from_text.config.strategy == excite.config_pb.STRATEGY_PA
    from_text.delete()

    with pytest.raises(ValueError):
        excite.session_config("state_dim: oops")
    # An unknown field is named with the valid ones in proto (snake_case) names.
    with pytest.raises(ValueError, match=r"'no_such_field' is not a field of SessionConfig"):
        excite.session_config({"no_such_field": 1})
    with pytest.raises(ValueError, match=r"'state_bound' .*did you mean 'state_bounds'.* "
                                         r"its fields: .*input_bounds"):
        excite.session_config({"state_bound": [[0, 1]]})
    with pytest.raises(ValueError, match=r"kernel\.'fitt' is not a field of KernelConfig"):
        excite.session_config({"kernel": {"fitt": True}})
    # Textproto takes short enum names in any case too; strings and comments stay.
    short = excite.session_config(
        'strategy: Auto  # strategy: nope\ntarget: delta\nauto { members: [rec, ROI] }')
    assert short.strategy == excite.config_pb.STRATEGY_AUTO
    assert short.target == excite.config_pb.TARGET_DELTA
    assert list(short.auto.members) == [excite.config_pb.STRATEGY_REC,
                                        excite.config_pb.STRATEGY_ROI]
    assert excite.session_config('state_names: ["strategy: rec"]').state_names == [
        "strategy: rec"]
    # Strategy names in any case, short or enum, also auto's members; an unknown
    # one lists the valid names (issue 31).
    for name in ("REC", "Rec", "STRATEGY_REC", "strategy_rec"):
        assert excite.session_config({"strategy": name}).strategy == (
            excite.config_pb.STRATEGY_REC)
    auto = excite.session_config({"strategy": "auto",
                                  "auto": {"members": ["rec", "RANDOM"]}})
    assert list(auto.auto.members) == [excite.config_pb.STRATEGY_REC,
                                       excite.config_pb.STRATEGY_RANDOM]
    # auto's chooser too, in a dict and in textproto.
    portfolio = excite.config_pb.AutoConfig.CHOOSER_PORTFOLIO
    assert excite.session_config({"auto": {"chooser": "Portfolio"}}).auto.chooser == (
        portfolio)
    assert excite.session_config("auto { chooser: portfolio }").auto.chooser == portfolio
    with pytest.raises(ValueError, match="'best' is not one of bandit, portfolio"):
        excite.session_config({"auto": {"chooser": "best"}})
    with pytest.raises(ValueError, match="'foo' is not one of rec, pa, greedy"):
        excite.session_config({"strategy": "foo"})
    # A path that is not there is said to be missing, not parsed as textproto.
    with pytest.raises(FileNotFoundError, match="not found: sim/configs/nope.textproto"):
        excite.session_config("sim/configs/nope.textproto")
    with pytest.raises(grpc.RpcError) as error:  # the server validates values
        client.create_session(linear_config(state_dim=0))
    assert error.value.code() == grpc.StatusCode.INVALID_ARGUMENT


def test_add_data_numbers_sequences_and_ignores_duplicates(client):
    session = client.create_session(linear_config())
    x, u, x_next, _, _ = linear_data(10, seed=1)
    reply = session.add(x, u, x_next, batch_size=3)  # 4 messages in one stream
    assert (reply.stored, reply.duplicates, reply.sample_count) == (10, 0, 10)

    again = session.add(x, u, x_next, sequences=np.arange(10))  # a retried batch
    assert (again.stored, again.duplicates, again.sample_count) == (0, 10, 10)

    more = session.add(x[:2], u[:2], x_next[:2])  # numbered 10, 11
    assert (more.stored, more.sample_count) == (2, 12)
    assert session.refresh().last_sequence == 11

    with pytest.raises(ValueError):
        session.add(x, u[:3], x_next)  # row counts differ
    bad = np.array(x)
    bad[0, 0] = np.nan
    with pytest.raises(grpc.RpcError) as error:
        session.add(bad, u, x_next, sequences=np.arange(100, 110))
    assert error.value.code() == grpc.StatusCode.INVALID_ARGUMENT
    session.delete()


def test_predict_learns_a_linear_plant(client):
    session = client.create_session(linear_config())
    with pytest.raises(grpc.RpcError) as error:  # no data, no model
        session.predict(np.zeros((1, 3)))
    assert error.value.code() == grpc.StatusCode.FAILED_PRECONDITION

    x, u, x_next, _, _ = linear_data(60, seed=2)
    assert session.add(x, u, x_next).sample_count == 60
    _, _, _, x_test, truth = linear_data(50, seed=99)
    u_test = linear_data(50, seed=98)[1]
    truth = x_test @ A.T + u_test @ B.T

    prediction = session.predict(np.hstack([x_test, u_test]))
    assert prediction.mean.shape == (50, 2) and prediction.variance.shape == (50, 2)
    assert np.all(prediction.variance > 0)
    rmse = np.sqrt(np.mean(np.sum((prediction.mean - truth) ** 2, axis=1)))
    # "The state stays where it is" is off by |x_next - x|, about 0.1 here.
    baseline = np.sqrt(np.mean(np.sum((x_test - truth) ** 2, axis=1)))
    assert rmse < 0.03 and rmse < 0.3 * baseline, (rmse, baseline)
    assert np.all(prediction.variance < 0.01)

    same = session.predict(states=x_test, inputs=u_test)
    np.testing.assert_allclose(same.mean, prediction.mean)
    noisy = session.predict(np.hstack([x_test, u_test]), include_noise=True)
    assert np.all(noisy.variance > prediction.variance)
    assert prediction.model_version == session.refresh().model_version

    with pytest.raises(ValueError):
        session.predict(np.zeros((4, 2)))  # z needs state_dim + input_dim columns
    with pytest.raises(grpc.RpcError) as error:  # the server checks shapes too
        client.stub.Predict(excite.pb.PredictRequest(session=session.name, inputs=[0.0] * 4))
    assert error.value.code() == grpc.StatusCode.INVALID_ARGUMENT
    session.delete()


def test_angles_predict_the_same_a_turn_later(client):
    # A dict config naming an angle: the server models x0 on the circle.
    session = client.create_session(linear_config(
        angle_dims=[0], state_bounds=[[-np.pi, np.pi], [-1.0, 1.0]]))
    assert list(session.config.angle_dims) == [0]
    x, u, x_next, _, _ = linear_data(40, seed=4)
    session.add(x, u, x_next)
    z = np.hstack([x[:5], u[:5]])
    turned = z.copy()
    turned[:, 0] += np.array([1, -1, 3, 2, -4]) * 2 * np.pi
    a, b = session.predict(z), session.predict(turned)
    np.testing.assert_allclose(b.mean[:, 0] - a.mean[:, 0], turned[:, 0] - z[:, 0],
                               atol=1e-9)
    np.testing.assert_allclose(b.mean[:, 1], a.mean[:, 1], atol=1e-9)
    np.testing.assert_allclose(b.variance, a.variance, rtol=1e-9)
    # Two lengthscales for the angle (its sine and cosine), one each for x1 and u.
    outputs = session.refresh().info.outputs
    assert [len(o.hyperparameters.lengthscales) for o in outputs] == [4, 4]
    with pytest.raises(excite.InvalidArgument) as error:
        client.create_session(linear_config(angle_dims=[2]))
    assert error.value.violations[0][0] == "config.angle_dims[0]", error.value.violations
    session.delete()


@pytest.mark.parametrize("strategy", ["rec", "pa"])
def test_plan_respects_bounds_and_strategy(client, strategy):
    session = client.create_session(linear_config(strategy=strategy, horizon=4))
    with pytest.raises(grpc.RpcError) as error:
        session.plan([0.0, 0.0])
    assert error.value.code() == grpc.StatusCode.FAILED_PRECONDITION
    x, u, x_next, _, _ = linear_data(20, seed=4)
    session.add(x, u, x_next)

    state = np.array([0.2, -0.1])
    plan = session.plan(state)
    assert plan.inputs.shape == (4, 1)
    assert plan.predicted_states.shape == (4, 2) and plan.predicted_variances.shape == (4, 2)
    assert np.all(np.abs(plan.inputs) <= 1.0 + 1e-9)
    np.testing.assert_allclose(plan.predicted_states[0], state)
    assert np.all(plan.predicted_variances > 0)
    assert plan.apply_count == (1 if strategy == "rec" else 4)
    assert plan.planned_by == strategy
    assert plan.to_apply.shape == (plan.apply_count, 1)
    assert plan.solver_status.startswith("SOLVER_STATUS_")
    assert plan.solver_status != "SOLVER_STATUS_UNSPECIFIED"
    assert np.isfinite(plan.objective) and plan.wall_time_ms > 0
    with pytest.raises(grpc.RpcError) as error:
        client.stub.PlanInputs(excite.pb.PlanInputsRequest(session=session.name, state=[1.0]))
    assert error.value.code() == grpc.StatusCode.INVALID_ARGUMENT
    session.delete()


def test_history_holds_plans_and_the_learning_curve(client):
    session = client.create_session(linear_config())
    x, u, x_next, _, _ = linear_data(40, seed=6)
    session.add(x[:20], u[:20], x_next[:20])
    plan = session.plan([0.1, 0.2])
    # Predicted by hand before the batch is added: what the history scores.
    predicted = session.predict(np.hstack([x[20:], u[20:]]))
    session.add(x[20:], u[20:], x_next[20:])
    history = session.history()
    assert isinstance(history, excite.History)
    np.testing.assert_array_equal(history.plan_samples, [20])
    assert history.plan_objectives[0] == plan.objective
    assert history.plan_planned_by == ("rec",)
    assert history.plan_solver_status == (plan.solver_status,)
    np.testing.assert_array_equal(history.error_samples, [20])
    expected = np.sqrt(np.mean((x_next[20:] - predicted.mean) ** 2, axis=0))
    np.testing.assert_allclose(history.error_rmse, [expected], rtol=1e-9)
    assert history.mean_std.shape == (len(history.std_samples), 2)
    assert list(history.std_samples) == [20, 40] and np.all(history.mean_std > 0)
    session.delete()


def test_rollout_returns_the_propagated_trajectory(client):
    session = client.create_session(linear_config())
    x, u, x_next, _, _ = linear_data(30, seed=9)
    session.add(x, u, x_next)
    plan = session.plan([0.1, -0.1])
    rolled = session.rollout([0.1, -0.1], plan.inputs, state_variance=[1e-4, 2e-4])
    assert isinstance(rolled, excite.Rollout)
    steps = plan.inputs.shape[0]
    assert rolled.means.shape == (steps + 1, 2) and rolled.covariances.shape == (steps + 1, 2, 2)
    np.testing.assert_array_equal(rolled.means[0], [0.1, -0.1])
    np.testing.assert_allclose(np.diagonal(rolled.covariances, axis1=1, axis2=2),
                               rolled.variances)
    # Step 1's mean is Predict's at (x_0, u_0); the plan's own states follow the mean.
    first = session.predict(np.hstack([[0.1, -0.1], plan.inputs[0]])[None, :])
    np.testing.assert_allclose(rolled.means[1], first.mean[0], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(rolled.means[:steps], plan.predicted_states, atol=1e-9)
    with pytest.raises(ValueError, match="one state of 2 numbers"):
        session.rollout([0.1], plan.inputs)
    session.delete()


def test_plan_ahead_of_pending_inputs(client):
    session = client.create_session(linear_config())
    x, u, x_next, _, _ = linear_data(30, seed=9)
    session.add(x, u, x_next)
    pending = [0.5, -0.25]  # input_dim 1: one number per step
    plan = session.plan([0.1, -0.1], pending_inputs=pending)
    assert plan.start_step == 2 and session.plan([0.1, -0.1]).start_step == 0
    rolled = session.rollout([0.1, -0.1], np.reshape(pending, (2, 1)))
    np.testing.assert_allclose(plan.predicted_states[0], rolled.means[2], rtol=1e-12)
    with pytest.raises(excite.InvalidArgument, match="pending_inputs"):
        session.plan([0.1, -0.1], pending_inputs=np.zeros((50, 1)))
    with pytest.raises(ValueError, match=r"pending_inputs: expected shape \(n, 1\)"):
        session.plan([0.1, -0.1], pending_inputs=np.zeros((2, 3)))
    session.delete()


@pytest.mark.parametrize("sparse,linear_mean",
                         [(False, False), (True, False), (False, True), (True, True)])
def test_exported_model_predicts_like_the_server(client, tmp_path, sparse, linear_mean):
    config = linear_config(angle_dims=[0])
    if sparse:
        config["sparse"] = {"above_samples": 10, "max_inducing": 8}
    if linear_mean:
        config["prior_mean"] = "PRIOR_MEAN_LINEAR"
    session = client.create_session(config)
    x, u, x_next, _, _ = linear_data(30, seed=11)
    session.add(x, u, x_next)
    path = tmp_path / "linear.model"
    returned = session.export_model(path)
    model = excite.Model.load(path)
    # A constant prior mean is written as version 1, which older readers read.
    assert path.read_bytes()[8] == model.format_version == (2 if linear_mean else 1)
    assert np.any(model._prior_slopes != 0) == linear_mean
    assert model.state_dim == 2 and model.input_dim == 1 and model.angle_dims == [0]
    assert model.sample_count == 30 and model.model_version == returned.model_version >= 2
    rng = np.random.default_rng(5)
    z = rng.uniform(-4, 4, size=(300, 3))  # beyond the data and past +-pi
    # Variances near 0 (cancellation) carry an absolute rounding error of a few eps
    # of the prior variance, amplified by the conditioning of K: 1e-10 of it is the
    # floor.
    prior = max(s ** 2 * o.signal_variance for s, o in zip(model._output_std, model._outputs))
    for include_noise in (False, True):
        served = session.predict(z, include_noise=include_noise)
        local = model.predict(z, include_noise=include_noise)
        np.testing.assert_allclose(local.mean, served.mean, rtol=1e-9, atol=1e-15)
        np.testing.assert_allclose(local.variance, served.variance, rtol=1e-9,
                                   atol=1e-10 * prior + 1e-15)
    np.testing.assert_allclose(model.predict(z[0]).mean, served.mean[:1], rtol=1e-9)
    with pytest.raises(ValueError, match=r"expected shape \(n, 3\)"):
        model.predict(np.zeros((2, 2)))
    newer = bytearray(path.read_bytes())
    newer[8] = excite.model.FORMAT_VERSION + 1
    with pytest.raises(excite.ModelFileError, match="format version 3; this reader knows"):
        excite.Model(bytes(newer))
    with pytest.raises(excite.ModelFileError, match="not an excite model file"):
        excite.Model(path.read_bytes()[:-5])
    session.delete()


def test_model_free_strategy_plans_without_data_or_predictions(client):
    session = client.create_session(linear_config(strategy="random", horizon=6))
    plan = session.plan([0.0, 0.0])  # no data needed
    assert plan.inputs.shape == (6, 1) and np.all(np.abs(plan.inputs) <= 1.0)
    assert plan.predicted_states.shape == (0, 2) and plan.predicted_variances.shape == (0, 2)
    assert plan.apply_count == 6 and plan.to_apply.shape == (6, 1)
    session.delete()


def test_stream_sends_transitions_as_they_come(client):
    session = client.create_session(linear_config())
    x, u, x_next, _, _ = linear_data(10, seed=5)
    with session.stream(batch_size=4) as stream:
        for i in range(10):
            stream.send(x[i], u[i], x_next[i])
    assert (stream.result.stored, stream.result.sample_count) == (10, 10)
    assert stream.acknowledged == 10 and stream.unacknowledged() == []
    assert session.refresh().sample_count == 10 and session.last_sequence == 9
    session.delete()


def test_flush_waits_for_storage_and_plan_flushes_open_streams(client):
    session = client.create_session(linear_config(horizon=3))
    x, u, x_next, _, _ = linear_data(40, seed=6)
    with session.stream(batch_size=100) as stream:  # nothing goes out by itself
        for i in range(30):
            stream.send(x[i], u[i], x_next[i])
        assert stream.acknowledged == 0
        stream.flush()
        assert stream.acknowledged == 30 and stream.unacknowledged() == []
        assert session.refresh().sample_count == 30
        for i in range(30, 40):
            stream.send(x[i], u[i], x_next[i])
        plan = session.plan(x[39])  # flushes first: plans on all 40
        assert stream.acknowledged == 40
        # No data was stored after the plan: it was made with the newest model.
        assert session.refresh().sample_count == 40
        assert plan.model_version == session.model_version
    assert session._open_streams == []  # closed streams are forgotten
    session.delete()


def test_stream_acknowledges_each_message_and_says_what_to_resend(client):
    session = client.create_session(linear_config())
    x, u, x_next, _, _ = linear_data(12, seed=7)
    stream = session.stream(batch_size=4).__enter__()
    for i in range(8):
        stream.send(x[i], u[i], x_next[i])
    deadline = time.time() + 10
    while stream.acknowledged < 8 and time.time() < deadline:
        time.sleep(0.01)
    assert stream.acknowledged == 8  # two messages, each stored then acknowledged
    assert session.refresh().sample_count == 8
    # A transition the server refuses ends the stream; the acknowledged ones stay.
    stream.send(x[8], u[8], x_next[8])
    stream.send([float("nan"), 0.0], u[9], x_next[9])
    with pytest.raises(grpc.RpcError) as error:
        stream.close()
    assert error.value.code() == grpc.StatusCode.INVALID_ARGUMENT
    assert "message 2" in error.value.details()
    assert [t.sequence for t in stream.unacknowledged()] == [8, 9]
    assert session.refresh().sample_count == 8
    session.delete()


def test_invalid_argument_carries_every_field_violation(client):
    config = excite.session_config(linear_config())
    config.noise.variance = -1
    config.input_bounds[0].lower = 5
    config.strategy = 42
    with pytest.raises(excite.InvalidArgument) as error:
        client.create_session(config)
    assert error.value.code() == grpc.StatusCode.INVALID_ARGUMENT  # still an RpcError
    assert isinstance(error.value, grpc.RpcError)
    fields = [field for field, _ in error.value.violations]
    assert fields == ["config.input_bounds[0]", "config.noise.variance", "config.strategy"]
    assert "valid: STRATEGY_REC" in dict(error.value.violations)["config.strategy"]
    assert "3 problems" in error.value.details() and "config.noise.variance" in str(error.value)


def test_unparsable_request_bytes_are_invalid_argument(client):
    """gRPC itself answers bytes it cannot parse with INTERNAL and no message; the
    server says INVALID_ARGUMENT instead."""
    raw = dict(request_serializer=lambda b: b, response_deserializer=lambda b: b)
    get = client.channel.unary_unary("/excite.v1.ExplorationService/GetSession", **raw)
    for payload in (b"\xff\xff\xff\xff", b"\x0a\x02\xc3\x28"):  # garbage; name not UTF-8
        with pytest.raises(grpc.RpcError) as error:
            get(payload, timeout=10)
        assert error.value.code() == grpc.StatusCode.INVALID_ARGUMENT
        assert "could not be parsed" in error.value.details()


def test_an_unparsable_stream_message_ends_the_stream_unacknowledged(client):
    """In a stream gRPC ends the server's reading at bytes it cannot parse, as at
    the client's end: StreamData acknowledges what came before, then ends, and the
    unparsable message and those after it are neither stored nor acknowledged."""
    raw = dict(request_serializer=lambda b: b, response_deserializer=lambda b: b)
    session = client.create_session(linear_config())
    x, u, x_next, _, _ = linear_data(6, seed=8)
    good = [excite.pb.AddDataRequest(session=session.name, transitions=session._transitions(
        x[i:i + 3], u[i:i + 3], x_next[i:i + 3], None, None)).SerializeToString()
        for i in (0, 3)]
    stream = client.channel.stream_stream("/excite.v1.ExplorationService/StreamData", **raw)
    acks = [excite.pb.AddDataAck.FromString(a)
            for a in stream(iter([good[0], b"\xff\xff\xff", good[1]]), timeout=10)]
    assert [(a.message_index, a.stored) for a in acks] == [(0, 3)]
    assert session.refresh().sample_count == 3
    session.delete()


def test_sessions_survive_a_restart(tmp_path):
    first = ServerProcess(tmp_path).start()
    with excite.Client(first.address) as c:
        session = c.create_session(linear_config(), session_id="durable")
        x, u, x_next, _, _ = linear_data(8, seed=6)
        session.add(x, u, x_next)
    assert first.stop() == 0

    second = ServerProcess(tmp_path).start()
    try:
        with excite.Client(second.address) as c:
            again = c.session("durable")
            assert again.sample_count == 8 and again.last_sequence == 7
            assert again.predict(np.zeros((2, 3))).mean.shape == (2, 2)
    finally:
        assert second.stop() == 0


def test_export_import_round_trip(client, tmp_path):
    # refit.never: the archived hyperparameters are used as they are after import.
    session = client.create_session(linear_config(refit={"never": True}),
                                    session_id="py-arch")
    x, u, x_next, _, _ = linear_data(12, seed=8)
    session.add(x, u, x_next)
    z = np.hstack([x[:3], u[:3]])
    before = session.predict(z).mean  # the one fit
    path = tmp_path / "py-arch.excite"
    archive = client.export_session("py-arch", path=path)
    assert archive.format_version == 1 and archive.session_id == "py-arch"
    assert [t.sequence for t in archive.samples] == list(range(12))
    np.testing.assert_array_equal([list(t.state) for t in archive.samples], x)
    assert len(archive.hyperparameters) == 2
    assert path.read_bytes() == archive.SerializeToString()
    session.delete()

    restored = client.import_session(path)  # from the file
    assert restored.name == "sessions/py-arch" and restored.sample_count == 12
    assert restored.config == archive.config
    np.testing.assert_allclose(restored.predict(z).mean, before, rtol=0, atol=1e-9)
    copy = client.import_session(archive.SerializeToString(), session_id="py-arch-copy")
    assert copy.name == "sessions/py-arch-copy" and copy.sample_count == 12
    with pytest.raises(grpc.RpcError) as error:
        client.import_session(archive)  # its id is taken now
    assert error.value.code() == grpc.StatusCode.ALREADY_EXISTS
    with pytest.raises(grpc.RpcError) as error:
        client.export_session("py-no-such")
    assert error.value.code() == grpc.StatusCode.NOT_FOUND
    restored.delete()
    copy.delete()


def test_duffing_example_explores_and_reports_rmse(server):
    example = REPO / "client" / "python" / "examples" / "duffing.py"
    result = subprocess.run(
        [sys.executable, str(example), f"--server={server.address}", "--samples=30",
         "--every=10", "--horizon=5", "--points=200"],
        capture_output=True, text=True, timeout=300,
        env=dict(os.environ, PYTHONPATH=str(REPO / "client" / "python")))
    assert result.returncode == 0, result.stdout + result.stderr
    rmse = [float(v) for v in re.findall(r"^samples +\d+ +rmse ([0-9.]+)", result.stdout, re.M)]
    assert len(rmse) == 3, result.stdout
    assert all(np.isfinite(rmse)) and rmse[-1] < rmse[0], result.stdout
    assert re.search(r"^final rmse [0-9.]+ after 30 samples", result.stdout, re.M)


def test_mpc_example_controls_the_pendulum_with_the_loaded_model(server, tmp_path):
    example = REPO / "client" / "python" / "examples" / "mpc_pendulum.py"
    model_file = tmp_path / "pendulum.model"
    result = subprocess.run(
        [sys.executable, str(example), f"--server={server.address}", "--samples=60",
         f"--model_file={model_file}"],
        capture_output=True, text=True, timeout=300,
        env=dict(os.environ, PYTHONPATH=str(REPO / "client" / "python")))
    assert result.returncode == 0, result.stdout + result.stderr
    assert model_file.stat().st_size > 0
    found = re.search(r"model-based control ([0-9.]+) rad, u = 0: ([0-9.]+) rad",
                      result.stdout)
    assert found, result.stdout
    learned, passive = float(found.group(1)), float(found.group(2))
    # Without input the pendulum rests at 0, 0.25 rad off; the learned model holds it
    # much nearer the target.
    assert passive > 0.2 and learned < 0.5 * passive, result.stdout


def test_stubs_are_generated_from_the_current_protos():
    from conftest import codegen
    stamp = pathlib.Path(codegen.STAMP).read_text().strip()
    assert stamp == codegen.digest(codegen.proto_dir())
    from excite.v1 import exploration_service_pb2_grpc
    assert hasattr(exploration_service_pb2_grpc, "ExplorationServiceStub")
    assert excite.pb.__file__ == str(pathlib.Path(codegen.STUB_DIR) /
                                     "exploration_service_pb2.py")


def test_session_calls_carry_the_routing_header():
    """Every call about a session names it in x-excite-session (for consistent-hash
    routing across replicas), checked against an in-process fake service."""
    from concurrent import futures

    from excite.v1 import exploration_service_pb2_grpc as pb_grpc

    seen = []

    class Fake(pb_grpc.ExplorationServiceServicer):
        def _record(self, method, context):
            seen.append((method, dict(context.invocation_metadata()).get("x-excite-session")))

        def CreateSession(self, request, context):
            self._record("CreateSession", context)
            return excite.pb.Session(name="sessions/" + request.session_id,
                                     config=request.config, last_sequence=-1)

        def GetSession(self, request, context):
            self._record("GetSession", context)
            return excite.pb.Session(name=request.name, config=excite.session_config(
                linear_config()), last_sequence=-1)

        def AddData(self, request_iterator, context):
            self._record("AddData", context)
            n = sum(len(r.transitions) for r in request_iterator)
            return excite.pb.AddDataResponse(stored=n, sample_count=n)

        def StreamData(self, request_iterator, context):
            self._record("StreamData", context)
            for i, r in enumerate(request_iterator):
                yield excite.pb.AddDataAck(message_index=i, stored=len(r.transitions))

        def Predict(self, request, context):
            self._record("Predict", context)
            return excite.pb.PredictResponse(mean=[0.0, 0.0], variance=[1.0, 1.0])

        def PlanInputs(self, request, context):
            self._record("PlanInputs", context)
            return excite.pb.PlanInputsResponse(inputs=[0.0], predicted_states=[0.0, 0.0],
                                                predicted_variances=[1.0, 1.0], horizon=1,
                                                apply_count=1)

        def DeleteSession(self, request, context):
            self._record("DeleteSession", context)
            return excite.pb.DeleteSessionResponse()

    server = grpc.server(futures.ThreadPoolExecutor(max_workers=2))
    pb_grpc.add_ExplorationServiceServicer_to_server(Fake(), server)
    port = server.add_insecure_port("127.0.0.1:0")
    server.start()
    try:
        with excite.Client(f"127.0.0.1:{port}") as c:
            s = c.create_session(linear_config(), session_id="routed")
            s.refresh()
            s.add([0.0, 0.0], [0.0], [0.0, 0.0])
            with s.stream() as stream:
                stream.send([0.0, 0.0], [0.0], [0.0, 0.0])
            s.predict(np.zeros(3))
            s.plan([0.0, 0.0])
            c.session("sessions/routed").delete()
    finally:
        server.stop(None)
    assert [m for m, _ in seen] == ["CreateSession", "GetSession", "AddData", "StreamData",
                                    "Predict", "PlanInputs", "GetSession", "DeleteSession"]
    assert all(header == "routed" for _, header in seen), seen


def make_certificates(directory):
    """A CA, a server certificate for 127.0.0.1 and a client certificate (openssl)."""
    script = """
    openssl req -x509 -newkey rsa:2048 -nodes -keyout ca.key -out ca.pem -days 1 \
        -subj /CN=excite-test-ca
    printf 'subjectAltName=IP:127.0.0.1,DNS:localhost\\n' > server.ext
    openssl req -newkey rsa:2048 -nodes -keyout server.key -out server.csr -subj /CN=localhost
    openssl x509 -req -in server.csr -CA ca.pem -CAkey ca.key -CAcreateserial \
        -out server.pem -days 1 -extfile server.ext
    openssl req -newkey rsa:2048 -nodes -keyout client.key -out client.csr \
        -subj /CN=excite-test-client
    openssl x509 -req -in client.csr -CA ca.pem -CAkey ca.key -CAcreateserial \
        -out client.pem -days 1
    """
    subprocess.run(["sh", "-e", "-c", script], cwd=directory, check=True,
                   capture_output=True)
    return {name: str(directory / name) for name in
            ("ca.pem", "server.pem", "server.key", "client.pem", "client.key")}


def test_mutual_tls_and_token(tmp_path, monkeypatch):
    files = make_certificates(tmp_path)
    (tmp_path / "token").write_text("s3cret-token\n")
    server = ServerProcess(tmp_path / "data", [
        f"--tls_cert={files['server.pem']}", f"--tls_key={files['server.key']}",
        f"--tls_client_ca={files['ca.pem']}", f"--auth_token_file={tmp_path / 'token'}",
    ]).start()
    try:
        monkeypatch.delenv("EXCITE_AUTH_TOKEN", raising=False)
        tls = dict(tls_ca=files["ca.pem"], tls_client_cert=files["client.pem"],
                   tls_client_key=files["client.key"], timeout_s=10)
        with excite.Client(server.address, auth_token="s3cret-token", **tls) as c:
            c.wait_for_ready(10)
            assert c.health() == "SERVING"
            session = c.create_session(linear_config(), "tls-1")
            session.add(*linear_data(5, 1)[:3])
            assert session.refresh().sample_count == 5
        with excite.Client(server.address, **tls) as c:  # no token: health only
            assert c.health() == "SERVING"
            with pytest.raises(grpc.RpcError) as error:
                list(c.list_sessions())
            assert error.value.code() == grpc.StatusCode.UNAUTHENTICATED
        monkeypatch.setenv("EXCITE_AUTH_TOKEN", "s3cret-token")  # the default source
        with excite.Client(server.address, **tls) as c:
            assert [s.id for s in c.list_sessions()] == ["tls-1"]
        with excite.Client(server.address, timeout_s=5) as c:  # plaintext: refused
            with pytest.raises(grpc.RpcError) as error:
                list(c.list_sessions())
            assert error.value.code() == grpc.StatusCode.UNAVAILABLE
        with pytest.raises(ValueError, match="go together"):
            excite.Client(server.address, tls_ca=files["ca.pem"],
                          tls_client_cert=files["client.pem"])
    finally:
        assert server.stop() == 0


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_unavailable_is_retried_within_the_window(tmp_path):
    port = free_port()
    address = f"127.0.0.1:{port}"
    # Nothing there and no retry: Unavailable at once.
    with excite.Client(address, timeout_s=5) as c:
        start = time.monotonic()
        with pytest.raises(excite.Unavailable):
            list(c.list_sessions())
        assert time.monotonic() - start < 2.5
    # A server that comes up a second later: the call succeeds within the window.
    late = ServerProcess(tmp_path, extra_args=[f"--listen={address}"])
    timer = threading.Timer(1.0, late.start)
    timer.start()
    try:
        with excite.Client(address, timeout_s=5, retry_unavailable_s=30) as c:
            assert list(c.list_sessions()) == []
    finally:
        timer.join()
        assert late.stop() == 0


def test_plan_says_what_shape_a_state_has(client):
    session = client.create_session(linear_config())
    with pytest.raises(ValueError, match=r"one state of 2 numbers .* got shape \(3,\)"):
        session.plan(np.zeros(3))
    session.delete()


def test_samples_round_trip_through_the_one_csv_layout(client, tmp_path):
    session = client.create_session(linear_config())
    x, u, x_next, _, _ = linear_data(12, seed=8)
    session.add(x, u, x_next, sequences=np.arange(100, 112))
    path = tmp_path / "samples.csv"
    data = session.samples()
    assert data.state_names == () and data.input_units == ()  # none named
    data.to_csv(path)
    lines = path.read_text().splitlines()
    assert lines[0] == "x0,x1,u0,x0_next,x1_next,sequence"  # excite-sim's header
    back = excite.Samples.from_csv(path, 2, 1)
    for field in ("states", "inputs", "next_states", "sequences"):
        np.testing.assert_array_equal(getattr(back, field), getattr(data, field))
    # Into another session with their numbers: all stored, then all duplicates.
    other = client.create_session(linear_config())
    assert other.add(back.states, back.inputs, back.next_states,
                     sequences=back.sequences).stored == 12
    assert other.add(back.states, back.inputs, back.next_states,
                     sequences=back.sequences).duplicates == 12
    # A session that names its dimensions writes them in the header.
    named = client.create_session(linear_config(state_names=["p", "v"], input_names=["f"]))
    named.add(x, u, x_next)
    named.samples().to_csv(tmp_path / "named.csv")
    assert (tmp_path / "named.csv").read_text().splitlines()[0] == "p,v,f,p_next,v_next,sequence"
    assert excite.Samples.from_csv(tmp_path / "named.csv", 2, 1).states.shape == (12, 2)
    named.delete()
    bad = tmp_path / "bad.csv"
    bad.write_text(lines[0] + "\n0.1,0.2,O.5,0.1,0.2,0\n")
    with pytest.raises(ValueError, match=r"line 2, column 3: 'O.5' is not a finite"):
        excite.Samples.from_csv(bad, 2, 1)
    bad.write_text("0.1,0.2,0.5,0.1,0.2,0.5\n")
    with pytest.raises(ValueError, match=r"line 1: the sequence number '0.5'"):
        excite.Samples.from_csv(bad, 2, 1)
    session.delete()
    other.delete()


def test_named_dimensions_are_kept_and_checked(client):
    named = client.create_session(linear_config(
        state_names=["position", "speed"], state_units=["m", "m/s"],
        input_names=["force"], input_units=["N"]))
    x, u, x_next, _, _ = linear_data(3, seed=9)
    named.add(x, u, x_next)
    data = named.samples()
    assert data.state_names == ("position", "speed") and data.input_units == ("N",)
    named.delete()
    with pytest.raises(excite.InvalidArgument) as error:
        client.create_session(linear_config(state_names=["position", "position"]))
    assert "names two dimensions" in dict(error.value.violations)["config.state_names[1]"]
    with pytest.raises(excite.InvalidArgument) as error:
        client.create_session(linear_config(input_names=["a", "b"]))
    assert "one entry per dimension (1)" in dict(error.value.violations)["config.input_names"]
