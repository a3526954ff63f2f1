#!/usr/bin/env python3
"""Plans per second from one excite-server with K sessions planning at once.

For each setup and each K in --sessions: K pendulum sessions (rec, horizon 15, the
same N samples of data, fitted first) each get one client thread that calls
PlanInputs in a loop for --seconds, from a fixed sequence of states of its own; a
further thread calls Predict (one point) on session 0 every 10 ms. Setups:

  one server, --planner_workers=W  for each W in --workers (0: the server's default)
  two servers, --planner_workers=1 each, the sessions alternating between them

Each K runs every setup --rounds times, the setups in turn (a machine's speed drifts
by 10 % within minutes here). Prints per setup and K: plans/s (median and range over
the rounds), and pooled over them PlanInputs p50/p99, Predict p99 on a planning
session, server CPU seconds per plan, and the solver statuses. The k-th plan of a
session is the same computation in every setup (same data, same states, same warm
starts), so each setup's plans are compared with the first setup's: the largest
relative objective difference and the plans whose status differs.

Then --writers threads each AddData one transition at a time to their own session
for --seconds on one server: AddData/s and p50/p99 (the store's write path).

    bench/load/plan_throughput.py [--server build/release/server/excite-server]
        [--sessions 1,2,4,8] [--workers 1,0] [--samples 300] [--seconds 20]
        [--writers 8] [--rounds 3]
"""
import argparse
import collections
import os
import sys
import threading
import time

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from support import LocalServer, pendulum_transitions as pendulum  # noqa: E402
from excite.client import Client  # noqa: E402

CONFIG = {"state_dim": 2, "input_dim": 1, "input_bounds": [[-2, 2]],
          "state_bounds": [[-3.2, 3.2], [-8, 8]], "angle_dims": [0],
          "noise": {"variance": 1e-6}, "strategy": "STRATEGY_REC", "horizon": 15,
          "planner": {"time_budget_s": 60}}


def percentile(values, q):
    return float(np.percentile(values, q)) if values else float("nan")


def run_setup(args, server_flags, k):
    """server_flags: one list of flags per server. Returns the measurements."""
    servers = [LocalServer(args.server, *flags) for flags in server_flags]
    try:
        clients = [Client(s.address, timeout_s=600) for s in servers]
        data = pendulum(args.samples, np.random.default_rng(0))
        sessions = []
        for i in range(k):
            session = clients[i % len(clients)].create_session(CONFIG)
            session.add(*data[:3], sequences=data[3])
            session.predict(np.zeros((1, 3)))  # fitted before the measurement
            sessions.append(session)
        stop = threading.Event()
        results = [[] for _ in range(k)]  # (ms, objective, status) per plan
        predict_ms = []

        def plan_loop(i):
            states = np.random.default_rng(100 + i).uniform([-3, -6], [3, 6], (1000, 2))
            for state in states:
                if stop.is_set():
                    return
                start = time.perf_counter()
                plan = sessions[i].plan(state)
                ms = 1e3 * (time.perf_counter() - start)
                if not stop.is_set():  # only plans that ended inside the window
                    results[i].append((ms, plan.objective, plan.solver_status))

        threads = [threading.Thread(target=plan_loop, args=(i,)) for i in range(k)]
        cpu_start = sum(s.cpu_seconds() for s in servers)
        wall_start = time.perf_counter()
        for t in threads:
            t.start()
        point = np.array([[0.3, 0.1, 0.5]])
        while time.perf_counter() - wall_start < args.seconds:
            start = time.perf_counter()
            sessions[0].predict(point)
            predict_ms.append(1e3 * (time.perf_counter() - start))
            time.sleep(0.01)
        stop.set()
        wall = time.perf_counter() - wall_start
        cpu = sum(s.cpu_seconds() for s in servers) - cpu_start
        for t in threads:
            t.join()
        return results, predict_ms, wall, cpu
    finally:
        for s in servers:
            s.stop()


def compare(results, reference):
    """Largest relative objective difference and status changes, plan by plan."""
    worst, changed, compared = 0.0, 0, 0
    for mine, theirs in zip(results, reference):
        for (_, objective, status), (_, ref_objective, ref_status) in zip(mine, theirs):
            compared += 1
            worst = max(worst, abs(objective - ref_objective) / max(abs(ref_objective), 1e-12))
            changed += status != ref_status
    return worst, changed, compared


def write_load(args):
    with LocalServer(args.server) as server:
        client = Client(server.address, timeout_s=600)
        sessions = [client.create_session(CONFIG) for _ in range(args.writers)]
        stop = threading.Event()
        latencies = [[] for _ in sessions]

        def add_loop(i):
            rng = np.random.default_rng(i)
            sequence = 0
            while not stop.is_set():
                x, u, x_next, seq = pendulum(1, rng, sequence)
                start = time.perf_counter()
                sessions[i].add(x, u, x_next, sequences=seq)
                latencies[i].append(1e3 * (time.perf_counter() - start))
                sequence += 1

        threads = [threading.Thread(target=add_loop, args=(i,)) for i in range(len(sessions))]
        start = time.perf_counter()
        for t in threads:
            t.start()
        time.sleep(args.seconds)
        stop.set()
        for t in threads:
            t.join()
        wall = time.perf_counter() - start
        ms = [v for per in latencies for v in per]
        print(f"AddData, {args.writers} writers (one transition per call, one session "
              f"each): {len(ms) / wall:.0f} calls/s, p50 {percentile(ms, 50):.1f} ms, "
              f"p99 {percentile(ms, 99):.1f} ms")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--server", default="build/release/server/excite-server")
    parser.add_argument("--sessions", default="1,2,4,8")
    parser.add_argument("--workers", default="1,0")
    parser.add_argument("--samples", type=int, default=300)
    parser.add_argument("--seconds", type=float, default=20)
    parser.add_argument("--writers", type=int, default=8)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    setups = [(f"1 server, --planner_workers={w}", [[f"--planner_workers={w}"]])
              for w in args.workers.split(",")]
    setups.append(("2 servers, --planner_workers=1 each",
                   [["--planner_workers=1"], ["--planner_workers=1"]]))
    print(f"pendulum, rec horizon 15, n = {args.samples}, {args.seconds:.0f} s per row, "
          f"{os.cpu_count()} CPUs")
    print("| setup | K | plans/s | PlanInputs p50 / p99 ms | Predict p99 ms (planning "
          "session) | CPU s per plan | statuses | vs first setup: max objective diff, "
          "status changes |")
    print("|---|---|---|---|---|---|---|---|")
    for k in [int(v) for v in args.sessions.split(",")]:
        runs = {label: [] for label, _ in setups}
        for _ in range(args.rounds):
            for label, flags in setups:
                runs[label].append(run_setup(args, flags, k))
        for label, _ in setups:
            rates = [sum(len(per) for per in r[0]) / r[2] for r in runs[label]]
            results = [plans for r in runs[label] for plans in r[0]]
            ms = [p[0] for per in results for p in per]
            predict_ms = [v for r in runs[label] for v in r[1]]
            cpu = sum(r[3] for r in runs[label])
            statuses = collections.Counter(p[2].replace("SOLVER_STATUS_", "").lower()
                                           for per in results for p in per)
            if label == setups[0][0]:
                versus = "reference"
            else:  # round by round: the k-th plan of session i in both
                worst, changed, compared = 0.0, 0, 0
                for mine, theirs in zip(runs[label], runs[setups[0][0]]):
                    w, c, n = compare(mine[0], theirs[0])
                    worst, changed, compared = max(worst, w), changed + c, compared + n
                versus = f"{100 * worst:.3f} %, {changed} of {compared}"
            print(f"| {label} | {k} | {np.median(rates):.1f} ({min(rates):.1f}-"
                  f"{max(rates):.1f}) | {percentile(ms, 50):.0f} / "
                  f"{percentile(ms, 99):.0f} | {percentile(predict_ms, 99):.1f} | "
                  f"{cpu / max(len(ms), 1):.3f} | "
                  f"{', '.join(f'{s} {c}' for s, c in sorted(statuses.items()))} | "
                  f"{versus} |", flush=True)
    if args.writers > 0:
        write_load(args)


if __name__ == "__main__":
    main()
