#!/usr/bin/python3
"""Learns a pendulum with excite, takes the model home, and controls the pendulum with
it without the server: model predictive control by random shooting on the loaded model.

    theta'' = -(g / l) sin(theta) - b theta' + u,   state (theta, theta'), |u| <= 3

1. Exploration: the server's `rec` strategy picks the inputs for --samples steps.
2. Export: Session.export_model() writes the model file (--model_file).
3. Control, offline: excite.Model.load() reads it; at each step 256 random input
   sequences of --horizon steps are rolled out through the model's mean (one batched
   predict per step) and the first input of the cheapest is applied. The task: hold
   the pendulum at theta* = 0.25 rad (it needs u = 9.81 sin(0.25) = 2.4 there).

It prints the mean |theta - theta*| over the last half of the control run, with the
learned model and with u = 0 for comparison.

    /usr/bin/python3 client/python/examples/mpc_pendulum.py --server=127.0.0.1:50051
"""

import argparse
import os
import tempfile

import excite
import grpc
import numpy as np

G_OVER_L, DAMPING, DT, SUBSTEPS = 9.81, 0.2, 0.1, 10
U_MAX = 3.0
TARGET = 0.25  # rad
NOISE_VARIANCE = 1e-4


def f(x, u):
    return np.stack([x[..., 1], -G_OVER_L * np.sin(x[..., 0]) - DAMPING * x[..., 1] + u],
                    axis=-1)


def step(x, u):
    """One sampling period of RK4 with u held."""
    h = DT / SUBSTEPS
    for _ in range(SUBSTEPS):
        k1 = f(x, u)
        k2 = f(x + 0.5 * h * k1, u)
        k3 = f(x + 0.5 * h * k2, u)
        k4 = f(x + h * k3, u)
        x = x + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
    return x


def explore(server, samples, seed, model_file):
    """Lets the server's rec strategy explore; returns the exported model."""
    rng = np.random.default_rng(seed)
    config = {"state_dim": 2, "input_dim": 1, "input_bounds": [[-U_MAX, U_MAX]],
              "state_bounds": [[-np.pi, np.pi], [-6.0, 6.0]], "angle_dims": [0],
              "noise": {"variance": NOISE_VARIANCE, "fit": True}, "strategy": "rec",
              "horizon": 10, "seed": seed}
    with excite.Client(server) as client:
        client.wait_for_ready(10)
        session = client.create_session(config)
        try:
            x = np.zeros(2)
            y = x + rng.normal(0, np.sqrt(NOISE_VARIANCE), 2)
            for _ in range(samples):
                try:
                    u = float(session.plan(y).to_apply[0, 0])
                except grpc.RpcError as e:  # too little data for a model yet
                    if e.code() != grpc.StatusCode.FAILED_PRECONDITION:
                        raise
                    u = float(rng.uniform(-U_MAX, U_MAX))
                x = step(x, u)
                y_next = x + rng.normal(0, np.sqrt(NOISE_VARIANCE), 2)
                session.add([y], [[u]], [y_next])
                y = y_next
            model = session.export_model(model_file)
        finally:
            session.delete()
    print(f"explored {samples} samples with rec; model file {model_file} "
          f"({os.path.getsize(model_file)} bytes)", flush=True)
    return model


def wrap(angle):
    return (angle + np.pi) % (2 * np.pi) - np.pi


def mpc_input(model, x, horizon, rng, candidates=256):
    """The first input of the cheapest of `candidates` random sequences, rolled out
    through the model's mean."""
    u = rng.uniform(-U_MAX, U_MAX, size=(candidates, horizon))
    u[0] = 0.0  # keep "do nothing" among the candidates
    states = np.repeat(x[None, :], candidates, axis=0)
    cost = np.zeros(candidates)
    for k in range(horizon):
        states = model.predict(np.column_stack([states, u[:, k]])).mean
        cost += wrap(states[:, 0] - TARGET) ** 2 + 0.01 * states[:, 1] ** 2
    return u[np.argmin(cost), 0]


def control(policy, steps):
    """Runs the true pendulum from rest under `policy`; returns mean |theta - theta*|
    over the second half."""
    x = np.zeros(2)
    errors = []
    for _ in range(steps):
        x = step(x, float(np.clip(policy(x), -U_MAX, U_MAX)))
        errors.append(abs(wrap(x[0] - TARGET)))
    return float(np.mean(errors[steps // 2:]))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--server", default="127.0.0.1:50051")
    parser.add_argument("--samples", type=int, default=60)
    parser.add_argument("--horizon", type=int, default=10)
    parser.add_argument("--steps", type=int, default=40, help="control steps")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--model_file", help="where to write the model (default: a temp file)")
    args = parser.parse_args(argv)
    model_file = args.model_file or os.path.join(tempfile.mkdtemp(), "pendulum.model")
    explore(args.server, args.samples, args.seed, model_file)

    model = excite.Model.load(model_file)  # from here on, no server
    rng = np.random.default_rng(args.seed)
    learned = control(lambda x: mpc_input(model, x, args.horizon, rng), args.steps)
    passive = control(lambda x: 0.0, args.steps)
    print(f"mean |theta - {TARGET}| over the last {args.steps - args.steps // 2} steps: "
          f"model-based control {learned:.3f} rad, u = 0: {passive:.3f} rad")


if __name__ == "__main__":
    main()
