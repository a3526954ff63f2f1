#!/usr/bin/python3
"""excite's ML-II fit beside scikit-learn's, on the same data, start and bounds.

For each (n, input dim) it draws one data set, runs excite's cold fit
(gp_fit_once: FitHyperparameters from the default start plus its random restarts)
and scikit-learn's GaussianProcessRegressor (ConstantKernel x ARD RBF +
WhiteKernel, one L-BFGS-B run from the same start, n_restarts_optimizer=0), and
prints their wall times and log marginal likelihoods as a Markdown table.

Data: inputs uniform in [-1, 1]^d (what the service's normalisation gives);
targets a smooth function of the first min(d, 6) inputs (the others are
irrelevant, as many of half-cheetah's 24 are for one output) plus noise of std
0.1, standardised. Both run on the system's BLAS (after scripts/setup.sh:
OpenBLAS's serial build, one thread each); excite is always run on it. To give scikit-learn OpenBLAS's threaded
build instead, unpack libopenblas0-pthread's .deb somewhere and run this script
with LD_LIBRARY_PATH=<there>/usr/lib/x86_64-linux-gnu/openblas-pthread; the
first line of the output says which BLAS and how many threads it got.

  bench/gp/fit_vs_sklearn.py --fit_binary=build/release/bench/gp/gp_fit_once
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
import warnings

import numpy as np
import threadpoolctl
from sklearn.exceptions import ConvergenceWarning
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel

# excite's FitOptions defaults (server/gp/hyperparameter_fit.h).
DEFAULT_BOUNDS = {
    "lengthscale": (0.05, 50.0),
    "signal_variance": (1e-2, 1e2),
    "noise_variance": (1e-6, 10.0),
}


def make_data(n, d, seed):
    rng = np.random.default_rng(seed)
    x = rng.uniform(-1.0, 1.0, size=(n, d))
    f = np.sin(3.0 * x[:, 0])
    if d > 1:
        f += 0.8 * x[:, 1] ** 2
    if d > 2:
        f += 0.5 * np.cos(2.0 * x[:, 2]) * x[:, 0]
    for j in range(3, min(d, 6)):
        f += 0.3 * np.sin((j - 1) * x[:, j])
    y = f + rng.normal(0.0, 0.1, size=n)
    return x, (y - y.mean()) / y.std()


def fit_excite(binary, x, y, bounds, predict_points):
    with tempfile.NamedTemporaryFile("w", suffix=".txt", delete=False) as f:
        f.write(f"{x.shape[0]} {x.shape[1]}\n")
        np.savetxt(f, np.column_stack([x, y]), fmt="%.17g")
        path = f.name
    try:
        out = subprocess.run(
            [binary, f"--data={path}",
             f"--min_lengthscale={bounds['lengthscale'][0]}",
             f"--max_lengthscale={bounds['lengthscale'][1]}",
             f"--min_signal_variance={bounds['signal_variance'][0]}",
             f"--max_signal_variance={bounds['signal_variance'][1]}",
             f"--min_noise_variance={bounds['noise_variance'][0]}",
             f"--max_noise_variance={bounds['noise_variance'][1]}",
             f"--predict_points={predict_points}"],
            check=True, capture_output=True, text=True,
            # excite on the system's BLAS, whatever this script's process was given.
            env={k: v for k, v in os.environ.items() if k != "LD_LIBRARY_PATH"}).stdout
    finally:
        os.unlink(path)
    return json.loads(out)


def fit_sklearn(x, y, bounds, predict_points):
    d = x.shape[1]
    kernel = (ConstantKernel(1.0, bounds["signal_variance"]) *
              RBF(np.ones(d), bounds["lengthscale"]) +
              WhiteKernel(1e-2, bounds["noise_variance"]))
    gp = GaussianProcessRegressor(kernel, alpha=1e-10, n_restarts_optimizer=0,
                                  normalize_y=False)
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        gp.fit(x, y)
    seconds = time.perf_counter() - t0
    xq = np.random.default_rng(1).uniform(-1.0, 1.0, size=(predict_points, x.shape[1]))
    t0 = time.perf_counter()
    gp.predict(xq, return_std=True)
    predict_seconds = time.perf_counter() - t0
    k = gp.kernel_
    return {
        "seconds": seconds,
        "predict_seconds": predict_seconds,
        "lml": float(gp.log_marginal_likelihood_value_),
        "lengthscales": list(np.atleast_1d(k.k1.k2.length_scale)),
        "signal_variance": float(k.k1.k1.constant_value),
        "noise_variance": float(k.k2.noise_level),
    }


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--fit_binary", required=True, help="path to gp_fit_once")
    p.add_argument("--sizes", default="1000x3,1000x24,2000x3,2000x24",
                   help="comma-separated NxD")
    p.add_argument("--max_lengthscale", type=float,
                   default=DEFAULT_BOUNDS["lengthscale"][1],
                   help="upper lengthscale bound for both (excite's default)")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--predict_points", type=int, default=10000,
                   help="after each fit, time a prediction (mean and std) at this "
                        "many points")
    p.add_argument("--max_lml_deficit", type=float, default=None,
                   help="exit 1 if excite's LML is below scikit-learn's by more "
                        "than this on any size (the ctest smoke run's check)")
    args = p.parse_args()
    bounds = dict(DEFAULT_BOUNDS)
    bounds["lengthscale"] = (bounds["lengthscale"][0], args.max_lengthscale)

    blas = [(i.get("internal_api"), i.get("version"), i.get("num_threads"),
             i.get("filepath")) for i in threadpoolctl.threadpool_info()
            if i.get("user_api") == "blas"]
    print(f"bounds: {bounds}; scikit-learn's BLAS (api, version, threads, file): "
          f"{blas}; cores {os.cpu_count()}")
    print("| n, d | excite fit | evaluations | scikit-learn fit | ratio | "
          "LML excite - sklearn | at upper bound (excite / sklearn) | "
          f"predict {args.predict_points} (excite / sklearn) |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    worst_deficit = 0.0
    for size in args.sizes.split(","):
        n, d = (int(v) for v in size.split("x"))
        x, y = make_data(n, d, args.seed)
        ours = fit_excite(args.fit_binary, x, y, bounds, args.predict_points)
        theirs = fit_sklearn(x, y, bounds, args.predict_points)
        cap = 0.999 * bounds["lengthscale"][1]
        at_cap = (sum(l >= cap for l in ours["lengthscales"]),
                  sum(l >= cap for l in theirs["lengthscales"]))
        print(f"| {n}, {d} | {ours['seconds']:.2f} s | {ours['evaluations']} | "
              f"{theirs['seconds']:.2f} s | {theirs['seconds'] / ours['seconds']:.1f}x | "
              f"{ours['lml'] - theirs['lml']:+.3f} | {at_cap[0]} / {at_cap[1]} | "
              f"{ours['predict_seconds']:.3f} / {theirs['predict_seconds']:.3f} s |",
              flush=True)
        worst_deficit = max(worst_deficit, theirs["lml"] - ours["lml"])
    if args.max_lml_deficit is not None and worst_deficit > args.max_lml_deficit:
        print(f"excite's LML is {worst_deficit:.3f} below scikit-learn's "
              f"(allowed: {args.max_lml_deficit})", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
