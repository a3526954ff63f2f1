#!/usr/bin/env python3
"""Latency of reads and writes on a session while it plans, on a real excite-server.

Starts the server binary on a temporary data directory (SQLite, the embedded
default) and one pendulum session (rec, horizon 15, N samples, fitted first).
One thread calls PlanInputs on it in a loop, another adds one new transition every
0.1 s (AddData, on a fixed schedule, so the data grow alike whatever the server);
beside them, for --seconds, a third calls Predict (one point) on the same session,
then GetSession, then Predict on a second, idle session (the reference). Prints p50 / p99 / max of each in ms and the plans made.

    bench/load/read_while_planning.py [--server build/release/server/excite-server]
                                      [--samples 300] [--seconds 20]
"""
import argparse
import os
import sys
import threading
import time

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from support import LocalServer, pendulum_transitions as pendulum  # noqa: E402
from excite.client import Client  # noqa: E402


def quantiles(ms):
    ms = np.asarray(ms)
    return (f"p50 {np.percentile(ms, 50):7.1f}  p99 {np.percentile(ms, 99):7.1f}  "
            f"max {ms.max():7.1f} ms  ({ms.size} calls)")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--server", default="build/release/server/excite-server")
    parser.add_argument("--samples", type=int, default=300)
    parser.add_argument("--seconds", type=float, default=20)
    args = parser.parse_args()
    with LocalServer(args.server) as server:
        client = Client(server.address, timeout_s=600)
        config = {"state_dim": 2, "input_dim": 1, "input_bounds": [[-2, 2]],
                  "state_bounds": [[-3.2, 3.2], [-8, 8]], "angle_dims": [0],
                  "noise": {"variance": 1e-6}, "strategy": "STRATEGY_REC", "horizon": 15}
        rng = np.random.default_rng(0)
        planning = client.create_session(config)
        idle = client.create_session(config)
        x, u, x_next, seq = pendulum(args.samples, rng)
        for session in (planning, idle):
            session.add(x, u, x_next, sequences=seq)
            session.predict(np.zeros((1, 3)))  # fitted before the measurement
        stop = threading.Event()
        plans = []

        def plan_loop():
            while not stop.is_set():
                start = time.perf_counter()
                planning.plan([0.1, -0.2])
                plans.append(1e3 * (time.perf_counter() - start))

        latencies = {"Predict, planning session": [], "GetSession, planning session": [],
                     "AddData, planning session": [], "Predict, idle session": []}

        def add_loop():  # one new transition every 0.1 s, on a fixed schedule
            sequence, due = args.samples, time.perf_counter()
            while not stop.is_set():
                due += 0.1
                start = time.perf_counter()
                planning.add(*pendulum(1, rng, sequence)[:3], sequences=[sequence])
                latencies["AddData, planning session"].append(
                    1e3 * (time.perf_counter() - start))
                sequence += 1
                time.sleep(max(0.0, due - time.perf_counter()))

        threads = [threading.Thread(target=plan_loop), threading.Thread(target=add_loop)]
        for t in threads:
            t.start()
        time.sleep(0.5)  # the first plan is under way
        end = time.perf_counter() + args.seconds
        point = np.array([[0.3, 0.1, 0.5]])
        while time.perf_counter() < end:
            for name, call in (("Predict, planning session", lambda: planning.predict(point)),
                               ("GetSession, planning session", planning.refresh),
                               ("Predict, idle session", lambda: idle.predict(point))):
                start = time.perf_counter()
                call()
                latencies[name].append(1e3 * (time.perf_counter() - start))
            time.sleep(0.01)
        stop.set()
        for t in threads:
            t.join()
        print(f"n = {args.samples}, rec horizon 15, {args.seconds:.0f} s")
        for name, ms in latencies.items():
            print(f"  {name:30s} {quantiles(ms)}")
        print(f"  {'PlanInputs':30s} {quantiles(plans)}")


if __name__ == "__main__":
    main()
