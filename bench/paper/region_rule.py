#!/usr/bin/python3
"""The region rule for a plant excite was never tuned on (issue 29's held-out plants).

A plant's region of interest (SessionConfig.state_bounds) and measurement noise are
fixed by this rule before any strategy runs on it, so that no choice can follow a
result:

  1. `--runs` (10) runs of `--samples` (300) transitions with uniformly random inputs
     in the input box, each held `--hold` (5) samples (excite-sim --strategy=random,
     seeds 0..runs-1), from the config's initial state, on a real excite-server;
  2. per state dimension, [p1, p99] of the measured states of all runs, widened by
     an eighth of its width on each side (a quarter in all), rounded outwards to two
     significant digits; an angle (angle_dims) gets one turn, [-pi, pi];
  3. measurement noise standard deviation 3 % of the region's smallest half-width,
     an angle's being pi (the pendulum's 0.22 is 7 % of its pi, 2.8 % of its 8 rad/s).

Prints the state_bounds lines and the noise variance to paste into the config. Run it
with a negligible noise variance in the config (1e-6), before the noise is known.

    /usr/bin/python3 bench/paper/region_rule.py --config sim/configs/acrobot.textproto
"""

import argparse
import csv
import glob
import math
import os
import re
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from run import DEFAULT_SERVER, DEFAULT_SIM, REPO, Server  # noqa: E402


def round_out(value, up):
    """`value` rounded away from the interval's inside to two significant digits."""
    if value == 0:
        return 0.0
    step = 10 ** (math.floor(math.log10(abs(value))) - 1)
    return (math.ceil if up else math.floor)(value / step) * step


def percentile(sorted_values, q):
    i = (len(sorted_values) - 1) * q
    lo, hi = math.floor(i), math.ceil(i)
    return sorted_values[lo] + (sorted_values[hi] - sorted_values[lo]) * (i - lo)


def angle_dims(config_path):
    text = open(config_path).read()
    m = re.search(r"^\s*angle_dims:\s*\[([^\]]*)\]", text, re.M)
    return [int(v) for v in m.group(1).split(",")] if m else []


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--config", required=True)
    ap.add_argument("--runs", type=int, default=10)
    ap.add_argument("--samples", type=int, default=300)
    ap.add_argument("--hold", type=int, default=5)
    ap.add_argument("--server_bin", default=DEFAULT_SERVER)
    ap.add_argument("--sim_bin", default=DEFAULT_SIM)
    args = ap.parse_args(argv)
    out = tempfile.mkdtemp(prefix="excite-region-")
    server = Server(args.server_bin, out, keep_data=False)
    try:
        address = server.wait_ready()
        for seed in range(args.runs):
            subprocess.run(
                [args.sim_bin, f"--server={address}", f"--config={args.config}",
                 "--strategy=random", f"--seed={seed}", f"--samples={args.samples}",
                 f"--session_override=signal {{ random_hold: {args.hold} }}",
                 f"--trajectory={out}/run{seed}.csv"],
                check=True, cwd=REPO, stdout=subprocess.DEVNULL)
    finally:
        server.stop()
    columns = None
    for path in sorted(glob.glob(f"{out}/run*.csv")):
        with open(path) as f:
            reader = csv.DictReader(f)
            names = [n for n in reader.fieldnames if re.fullmatch(r"x\d+", n)]
            if columns is None:
                columns = {n: [] for n in names}
            for row in reader:
                for n in names:
                    columns[n].append(float(row[n]))
    angles = angle_dims(args.config)
    half_widths = []
    print(f"# region rule (bench/paper/region_rule.py): {args.runs} random-input runs of "
          f"{args.samples} samples, inputs held {args.hold}")
    for j, (name, values) in enumerate(columns.items()):
        values.sort()
        if j in angles:
            half_widths.append(math.pi)
            print("  state_bounds { lower: -3.141592653589793 upper: 3.141592653589793 }"
                  f"  # {name}: an angle, one turn")
            continue
        p1, p99 = percentile(values, 0.01), percentile(values, 0.99)
        pad = (p99 - p1) / 8
        lo, hi = round_out(p1 - pad, up=False), round_out(p99 + pad, up=True)
        half_widths.append((hi - lo) / 2)
        print(f"  state_bounds {{ lower: {lo:g} upper: {hi:g} }}  # {name}: "
              f"p1 {p1:.3g}, p99 {p99:.3g}")
    std = 0.03 * min(half_widths)
    print(f"  noise {{ variance: {std * std:.3g} }}  # std {std:.3g}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
