#!/usr/bin/env python3
"""Plots a finished exploration from `excite-sim --trajectory=FILE`.

    sim/plot_trajectory.py FILE [--out FILE.png] [--dims 0,1]

Three panels: the measured states over the steps, the applied inputs over the
steps, and the visited states in two dimensions (--dims, default the first two),
coloured by step, so that one sees where the strategy went and when.
"""
import argparse
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def read_trajectory(path):
    """(steps, x, u, state names, input names) from the CSV excite-sim writes: a
    header of x.., u.., x.._next.., sequence, the config's dimension names when it
    has them (theta,theta_dot,tau,theta_next,theta_dot_next,sequence), else x0.., u0..."""
    with open(path, newline="") as f:
        rows = [row for row in csv.reader(f) if row and not row[0].startswith("#")]
    if len(rows) < 2:
        raise ValueError(f"{path}: no transitions")
    header = rows[0]
    dx = sum(1 for name in header if name.endswith("_next"))
    du = len(header) - 1 - 2 * dx
    if header[-1] != "sequence" or dx < 1 or du < 1 or header[dx + du:-1] != [
            name + "_next" for name in header[:dx]]:
        raise ValueError(f"{path}: not an excite-sim trajectory (header {header})")
    data = np.array([[float(v) for v in row] for row in rows[1:]])
    return data[:, -1], data[:, :dx], data[:, dx:dx + du], header[:dx], header[dx:dx + du]


def plot(path, out, dims):
    steps, x, u, state_names, input_names = read_trajectory(path)
    fig, axes = plt.subplots(1, 3, figsize=(15, 4))
    for i in range(x.shape[1]):
        axes[0].plot(steps, x[:, i], label=state_names[i])
    axes[0].set(xlabel="step", ylabel="measured state", title="states")
    axes[0].legend(fontsize="small")
    for j in range(u.shape[1]):
        axes[1].step(steps, u[:, j], where="post", label=input_names[j])
    axes[1].set(xlabel="step", ylabel="applied input", title="inputs")
    axes[1].legend(fontsize="small")
    a, b = dims if x.shape[1] > max(dims) else (0, 0)
    points = axes[2].scatter(x[:, a], x[:, b], c=steps, s=8, cmap="viridis")
    axes[2].set(xlabel=state_names[a], ylabel=state_names[b], title="visited states")
    fig.colorbar(points, ax=axes[2], label="step")
    fig.suptitle(f"{path}: {len(steps)} transitions")
    fig.tight_layout()
    fig.savefig(out, dpi=100)
    return len(steps)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("trajectory")
    parser.add_argument("--out", default="")
    parser.add_argument("--dims", default="0,1")
    args = parser.parse_args()
    out = args.out or args.trajectory.rsplit(".", 1)[0] + ".png"
    dims = tuple(int(v) for v in args.dims.split(","))
    try:
        n = plot(args.trajectory, out, dims)
    except (OSError, ValueError) as error:
        print(f"plot_trajectory: {error}", file=sys.stderr)
        return 1
    print(f"{n} transitions plotted to {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
