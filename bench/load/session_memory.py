#!/usr/bin/env python3
"""The memory budget's estimate against a real excite-server's peak memory.

Starts the server binary with a metrics endpoint on a temporary data directory,
then for each case (state_dim, input_dim, samples) creates one session with a
fitted kernel, streams the samples in batches of 100 with a Predict (a refit)
after the first and the last batch, and reports the growth of the server's peak
resident memory (VmHWM) beside the growth of excite_memory_estimate_bytes, the
estimate the budget counts. Also the resident memory of 1000 empty sessions.
The sessions are exact GPs unless --sparse_above is set (sparse.above_samples).

    bench/load/session_memory.py [--server build/release/server/excite-server]
                                 [--cases 2x1x500,2x1x1000,2x1x2000,8x2x1000]
                                 [--sparse_above 0]
"""
import argparse
import os
import re
import sys
import time
import urllib.request

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from support import LocalServer  # noqa: E402
from excite.client import Client  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--server", default="build/release/server/excite-server")
    parser.add_argument("--cases", default="2x1x500,2x1x1000,2x1x2000,8x2x1000")
    parser.add_argument("--metrics_port", type=int, default=19464)
    parser.add_argument("--sparse_above", type=int, default=0,
                        help="the sessions' sparse.above_samples (0: exact GPs)")
    args = parser.parse_args()
    for case in args.cases.split(","):
        state_dim, input_dim, samples = (int(v) for v in case.split("x"))
        run_case(args, state_dim, input_dim, samples)
    empty_sessions(args)


def start(args):
    return LocalServer(args.server, f"--metrics_listen=127.0.0.1:{args.metrics_port}")


def estimate_mib(args):
    url = f"http://127.0.0.1:{args.metrics_port}/metrics"
    text = urllib.request.urlopen(url, timeout=10).read().decode()
    return float(re.search(r"^excite_memory_estimate_bytes (\S+)$", text, re.M)
                 .group(1)) / 2**20


def run_case(args, state_dim, input_dim, samples):
    with start(args) as server:
        client = Client(server.address, timeout_s=3600)
        rng = np.random.default_rng(0)
        base_peak = server.status_mib("VmHWM")
        base_estimate = estimate_mib(args)
        session = client.create_session({
            "state_dim": state_dim, "input_dim": input_dim,
            "input_bounds": [[-3, 3]] * input_dim, "noise": {"variance": 1e-4},
            "kernel": {"fit": True, "restarts": 0, "max_iterations": 5},
            "planner": {"time_budget_s": 3600},
            "sparse": {"above_samples": args.sparse_above}})
        start_time = time.time()
        for first in range(0, samples, 100):
            m = min(100, samples - first)
            x = rng.uniform(-3, 3, (m, state_dim))
            u = rng.uniform(-3, 3, (m, input_dim))
            drift = np.sin(np.roll(x, 1, axis=1)) + u.sum(axis=1, keepdims=True)
            session.add(x, u, x + 0.05 * drift)
            if first == 0 or first + m == samples:
                session.predict(np.zeros((1, state_dim + input_dim)))  # a refit
        peak = server.status_mib("VmHWM") - base_peak
        estimate = estimate_mib(args) - base_estimate
        print(f"state_dim {state_dim}, input_dim {input_dim}, n={samples}: peak RSS "
              f"+{peak:.0f} MiB, estimate {estimate:.0f} MiB "
              f"(estimate / peak {estimate / peak:.2f}), {time.time() - start_time:.0f} s",
              flush=True)


def empty_sessions(args, count=1000):
    with start(args) as server:
        client = Client(server.address, timeout_s=3600)
        config = {"state_dim": 2, "input_dim": 1, "input_bounds": [[-3, 3]],
                  "noise": {"variance": 1e-4}, "kernel": {"fit": True}}
        client.create_session(config)  # first-use allocations out of the figure
        before = server.status_mib("VmRSS")
        for _ in range(count):
            client.create_session(config)
        after = server.status_mib("VmRSS")
        print(f"{count} empty sessions: +{after - before:.1f} MiB resident, "
              f"{(after - before) * 1024 / count:.1f} KiB each", flush=True)


if __name__ == "__main__":
    main()
