#!/usr/bin/env python3
"""The rec loop of one long pendulum session at the client, exact against sparse.

For each size n: starts the server binary on a temporary data directory, creates a
pendulum session (rec, horizon 15, the server's default refit policy), streams n
transitions of the pendulum under uniformly random torques held 5 steps, then runs
--steps rec steps from the last state: PlanInputs, apply the first input to the
pendulum, AddData of that one transition (durable), refits when the policy says.
Prints the step's p50 and slowest time at the client, the sparse model's inducing
points and the server's peak resident memory.

    bench/load/long_session.py [--server build/release/server/excite-server]
                               [--sizes 2000,10000] [--sparse_above 1000] [--steps 40]
                               [--max_inducing 0]
"""
import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from support import LocalServer  # noqa: E402
from excite.client import Client  # noqa: E402

DT, SUBSTEPS = 0.1, 10  # sim/configs/pendulum.textproto's plant


def pendulum_step(x, u):
    def f(s):
        return np.array([s[1], u - 0.1 * s[1] - 9.81 * np.sin(s[0])])
    h = DT / SUBSTEPS
    for _ in range(SUBSTEPS):
        k1 = f(x)
        k2 = f(x + h / 2 * k1)
        k3 = f(x + h / 2 * k2)
        k4 = f(x + h * k3)
        x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return x


def trajectory(rng, x, n):
    xs, us, nexts = [], [], []
    u = 0.0
    for k in range(n):
        if k % 5 == 0:
            u = rng.uniform(-3, 3)
        nxt = pendulum_step(x, u)
        xs.append(x)
        us.append([u])
        nexts.append(nxt + rng.normal(0, np.sqrt(0.05), 2))
        x = nxt
    return np.array(xs), np.array(us), np.array(nexts), x


def run(args, n, sparse_above):
    with LocalServer(args.server) as server:
        client = Client(server.address, timeout_s=3600)
        session = client.create_session({
            "state_dim": 2, "input_dim": 1, "input_bounds": [[-3, 3]],
            "state_bounds": [[-np.pi, np.pi], [-8, 8]],
            "noise": {"variance": 0.05, "fit": True}, "horizon": 15,
            "planner": {"time_budget_s": 3600},
            "sparse": {"above_samples": sparse_above,
                       "max_inducing": args.max_inducing}})
        rng = np.random.default_rng(n)
        xs, us, nexts, x = trajectory(rng, np.zeros(2), n)
        for first in range(0, n, 1000):
            session.add(xs[first:first + 1000], us[first:first + 1000],
                        nexts[first:first + 1000])
        t0 = time.perf_counter()
        session.predict(np.zeros((1, 3)))  # the first fit
        first_fit_s = time.perf_counter() - t0
        steps = []
        for _ in range(args.steps):
            t0 = time.perf_counter()
            plan = session.plan(x)
            u = plan.inputs[0]
            nxt = pendulum_step(x, u[0])
            measured = nxt + rng.normal(0, np.sqrt(0.05), 2)
            session.add(x[None, :], u[None, :], measured[None, :])
            steps.append(time.perf_counter() - t0)
            x = nxt
        inducing = [o.inducing_points for o in session.refresh().info.outputs]
        peak = server.status_mib("VmHWM")
        ms = 1000 * np.array(steps)
        print(f"n={n} sparse_above={sparse_above} max_inducing={args.max_inducing}: step p50 {np.median(ms):.1f} ms, "
              f"slowest {ms.max():.1f} ms ({args.steps} steps), first fit "
              f"{first_fit_s:.1f} s, inducing {inducing}, server peak RSS "
              f"{peak:.0f} MiB", flush=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--server", default="build/release/server/excite-server")
    parser.add_argument("--sizes", default="2000,10000")
    parser.add_argument("--sparse_above", type=int, default=1000,
                        help="sparse.above_samples (0: exact GPs)")
    parser.add_argument("--max_inducing", type=int, default=0,
                        help="sparse.max_inducing (0: the server's default)")
    parser.add_argument("--steps", type=int, default=40)
    args = parser.parse_args()
    for n in (int(v) for v in args.sizes.split(",")):
        run(args, n, args.sparse_above)


if __name__ == "__main__":
    main()
