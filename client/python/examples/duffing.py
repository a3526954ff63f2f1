#!/usr/bin/python3
"""Actively learns a damped Duffing oscillator, a plant written in Python, with excite.

    x'' + delta x' + alpha x + beta x^3 = u,   state (x, x'), input u

With alpha = -1, beta = 1 it is a double well (stable equilibria x = -1 and x = +1,
barrier 1/4 at x = 0); it starts at rest in the left well. |u| <= 0.5 is just enough
to tip it over the barrier (0.385 would hold it on the hill top), so the explorer has
to find out that there is a second well. The server chooses the inputs with the
session's strategy: rec by default; pa, greedy, sep, or the model-free prbs, chirp and
random for comparison. While a strategy that needs a model has too little data
(FAILED_PRECONDITION), the plant applies one uniformly random input.
Every `--every` samples it prints the RMSE of the model's predicted next state against
the true one on a fixed set of random (x, u) in the region of interest.

    /usr/bin/python3 client/python/examples/duffing.py --server=127.0.0.1:50051
"""

import argparse
import sys
import time

import excite
import grpc
import numpy as np

DELTA, ALPHA, BETA = 0.3, -1.0, 1.0  # damping, linear and cubic stiffness
DT, SUBSTEPS = 0.2, 10  # sampling period [s], RK4 steps per period
U_MAX = 0.5
REGION = np.array([[-2.0, 2.0], [-2.0, 2.0]])  # x, x' region of interest
NOISE_VARIANCE = 1e-3  # measurement noise of each state (std 0.03)


def f(x, u):
    """Continuous-time dynamics; x has shape (..., 2), u shape (...)."""
    return np.stack([x[..., 1], -DELTA * x[..., 1] - ALPHA * x[..., 0]
                     - BETA * x[..., 0] ** 3 + u], axis=-1)


def step(x, u):
    """One sampling period of RK4 with u held (batched over leading axes)."""
    h = DT / SUBSTEPS
    for _ in range(SUBSTEPS):
        k1 = f(x, u)
        k2 = f(x + 0.5 * h * k1, u)
        k3 = f(x + 0.5 * h * k2, u)
        k4 = f(x + h * k3, u)
        x = x + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
    return x


def session_config(strategy, horizon, seed):
    return {
        "state_dim": 2,
        "input_dim": 1,
        "input_bounds": [[-U_MAX, U_MAX]],
        "state_bounds": REGION.tolist(),
        "noise": {"variance": NOISE_VARIANCE, "fit": True},
        "kernel": {"fit": True},
        "target": "delta",
        "strategy": strategy,
        "horizon": horizon,
        "refit": {"every_samples": 1, "min_samples": 2},
        "seed": seed,
    }


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--server", default="127.0.0.1:50051")
    parser.add_argument("--strategy", default="rec",
                        choices=["rec", "pa", "greedy", "sep", "mi", "roi", "optimistic",
                                 "prbs", "chirp", "random"])
    parser.add_argument("--samples", type=int, default=80)
    parser.add_argument("--horizon", type=int, default=10)
    parser.add_argument("--every", type=int, default=10, help="RMSE every this many samples")
    parser.add_argument("--points", type=int, default=500, help="evaluation points")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--keep", action="store_true", help="keep the session at the end")
    args = parser.parse_args(argv)

    rng = np.random.default_rng(args.seed)
    eval_rng = np.random.default_rng(42)  # the same evaluation set for every run
    z_eval = np.column_stack([
        eval_rng.uniform(REGION[0, 0], REGION[0, 1], args.points),
        eval_rng.uniform(REGION[1, 0], REGION[1, 1], args.points),
        eval_rng.uniform(-U_MAX, U_MAX, args.points),
    ])
    truth = step(z_eval[:, :2], z_eval[:, 2])

    def measure(x):
        return x + rng.normal(0.0, np.sqrt(NOISE_VARIANCE), size=x.shape)

    with excite.Client(args.server) as client:
        client.wait_for_ready(10)
        session = client.create_session(session_config(args.strategy, args.horizon, args.seed))
        print(f"duffing: {session.name}, strategy {args.strategy}, {args.samples} samples, "
              f"server {args.server}", flush=True)
        x = np.array([-1.0, 0.0])  # at rest in the left well
        x_seen = (x[0], x[0])  # range of the true position
        y = measure(x)
        samples, history, plan_ms, start = 0, [], [], time.monotonic()
        try:
            while samples < args.samples:
                inputs = None
                try:
                    t = time.monotonic()
                    inputs = session.plan(y).to_apply[:, 0]
                    plan_ms.append(1000 * (time.monotonic() - t))
                except grpc.RpcError as e:
                    if e.code() != grpc.StatusCode.FAILED_PRECONDITION:
                        raise
                    # Not enough data for a model yet: one random input.
                if inputs is None:
                    inputs = rng.uniform(-U_MAX, U_MAX, size=1)
                inputs = np.clip(inputs, -U_MAX, U_MAX)[: args.samples - samples]
                states, applied, next_states = [], [], []
                for u in inputs:
                    x = step(x, u)
                    x_seen = (min(x_seen[0], x[0]), max(x_seen[1], x[0]))
                    y_next = measure(x)
                    states.append(y)
                    applied.append([u])
                    next_states.append(y_next)
                    y = y_next
                reply = session.add(states, applied, next_states)
                assert reply.stored == len(inputs), reply
                before, samples = samples, samples + len(inputs)
                if samples // args.every > before // args.every or samples == args.samples:
                    if samples >= 2:
                        mean = session.predict(z_eval).mean
                        rmse = float(np.sqrt(np.mean(np.sum((mean - truth) ** 2, axis=1))))
                        history.append((samples, rmse))
                        print(f"samples {samples:4d}  rmse {rmse:.4f}  x {x[0]:+.2f}"
                              + (f"  plan_ms {plan_ms[-1]:.0f}" if plan_ms else ""),
                              flush=True)
        finally:
            if not args.keep:
                session.delete()
        print(f"final rmse {history[-1][1]:.4f} after {samples} samples, "
              f"x visited [{x_seen[0]:+.2f}, {x_seen[1]:+.2f}], "
              f"{time.monotonic() - start:.1f} s"
              + (f", median plan {np.median(plan_ms):.0f} ms" if plan_ms else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
