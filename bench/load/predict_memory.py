#!/usr/bin/env python3
"""Peak memory and wall time of one large Predict call on a real excite-server.

Starts the server binary on a temporary data directory, creates a session with
fixed hyperparameters (no refit in the measurement), adds N pendulum-like
samples, then asks for P points in one Predict and reports the server's peak
resident memory (VmHWM) before and after, and the call's wall time.

    bench/load/predict_memory.py [--server build/release/server/excite-server]
                                 [--samples 1000] [--points 100000]
"""
import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from support import LocalServer  # noqa: E402
from excite.client import Client  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--server", default="build/release/server/excite-server")
    parser.add_argument("--samples", type=int, default=1000)
    parser.add_argument("--points", type=int, default=100000)
    args = parser.parse_args()
    with LocalServer(args.server,
                     f"--max_predict_points={max(args.points, 100000)}") as server:
        client = Client(server.address, timeout_s=3600)
        fixed = {"signal_variance": 1, "lengthscales": [1, 1, 1], "noise_variance": 1e-4}
        session = client.create_session({
            "state_dim": 2, "input_dim": 1, "input_bounds": [[-3, 3]],
            "noise": {"variance": 1e-6}, "kernel": {"fixed": [fixed, fixed]}})
        rng = np.random.default_rng(0)
        x = rng.uniform(-3, 3, (args.samples, 2))
        u = rng.uniform(-3, 3, (args.samples, 1))
        session.add(x, u, x + 0.05 * np.hstack([x[:, 1:], np.sin(x[:, :1]) + u]))
        session.predict(np.zeros((1, 3)))  # factorises the model
        before = server.status_mib("VmHWM")
        start = time.time()
        session.predict(rng.uniform(-3, 3, (args.points, 3)))
        seconds = time.time() - start
        after = server.status_mib("VmHWM")
        print(f"n={args.samples} points={args.points}: {seconds:.1f} s, server peak RSS "
              f"{before:.0f} -> {after:.0f} MiB (+{after - before:.0f})")


if __name__ == "__main__":
    main()
