#!/usr/bin/python3
"""A real-time plant against the lock-step loop (issue 30, item 2).

For each system, strategy and seed: one lock-step excite-sim run and one run per
rate with --realtime_hz, all at the same sample count, one at a time against one
excite-server on SQLite (the embedded default), so that a real-time run's plans
compete with nothing. Paired by seed: the RMSE ratio real-time / lock-step of
trial k uses seed k for both.

  bench/realtime/run.py --out DIR [--samples 150] [--seeds 3] [--first_seed 1]
  bench/realtime/run.py --report DIR...   re-aggregate the runs.csv of each DIR

Writes DIR/runs.csv (one row per run) and DIR/report.md. Standard library only.
"""

import argparse
import csv
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.abspath(os.path.join(HERE, "..", ".."))
sys.path.insert(0, os.path.join(REPO, "bench", "paper"))

from aggregate import paired_ratio  # noqa: E402  (the paper benchmark's paired bootstrap)
BUILD = os.path.join(REPO, "build", "release")
# The grid: the pendulum at 20 and 50 Hz, the unicycle at 20 Hz.
GRID = {"pendulum": [20.0, 50.0], "unicycle": [20.0]}
STRATEGIES = ["rec", "roi", "pa"]
FIELDS = ["system", "strategy", "seed", "hz", "samples", "final_rmse", "plans",
          "plan_ms_p50", "plan_ms_p90", "plan_ms_p99", "ticks_from_plan",
          "ticks_fell_back", "late_plans", "overruns", "wall_s"]


def start_server(data_dir):
    log = open(os.path.join(data_dir, "server.log"), "w")
    server = subprocess.Popen([os.path.join(BUILD, "server", "excite-server"),
                               "--listen=127.0.0.1:0", f"--data_dir={data_dir}/data"],
                              stdout=log, stderr=subprocess.STDOUT)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        with open(os.path.join(data_dir, "server.log")) as f:
            for line in f:
                if "listening on" in line:
                    return server, line.split("listening on")[1].split()[0]
        time.sleep(0.2)
    server.kill()
    sys.exit("excite-server did not start")


def run_one(address, system, strategy, seed, hz, samples, work):
    summary = os.path.join(work, f"{system}_{strategy}_{seed}_{hz:g}.json")
    command = [os.path.join(BUILD, "sim", "excite-sim"), f"--server={address}",
               f"--config={REPO}/sim/configs/{system}.textproto", f"--strategy={strategy}",
               f"--samples={samples}", f"--seed={seed}", f"--summary={summary}"]
    if hz > 0:
        command.append(f"--realtime_hz={hz:g}")
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"{' '.join(command)} failed:\n{done.stdout}\n{done.stderr}")
    with open(summary) as f:
        s = json.load(f)
    rt = s.get("realtime") or {}
    return {"system": system, "strategy": strategy, "seed": seed, "hz": hz,
            "samples": s["samples"], "final_rmse": s["final_rmse"], "plans": s["plans"],
            "plan_ms_p50": s["plan_ms_p50"], "plan_ms_p90": s["plan_ms_p90"],
            "plan_ms_p99": s["plan_ms_p99"], "ticks_from_plan": rt.get("ticks_from_plan", ""),
            "ticks_fell_back": rt.get("ticks_fell_back", ""),
            "late_plans": rt.get("late_plans", ""), "overruns": rt.get("overruns", ""),
            "wall_s": s["wall_s"]}


def report(rows):
    """Per (system, strategy, rate): paired RMSE ratios to lock-step and fallback share."""
    lock = {(r["system"], r["strategy"], int(r["seed"])): float(r["final_rmse"])
            for r in rows if float(r["hz"]) == 0}
    lines = ["| system | strategy | rate | seeds | final RMSE, real-time / lock-step: geometric "
             "mean [90 % interval], wins | fell back | late plans | plan ms p50 / p99 |",
             "|---|---|---|---|---|---|---|---|"]
    for system, rates in GRID.items():
        for strategy in STRATEGIES:
            for hz in rates:
                runs = [r for r in rows if r["system"] == system and
                        r["strategy"] == strategy and float(r["hz"]) == hz and
                        (system, strategy, int(r["seed"])) in lock]
                if not runs:
                    continue
                paired = paired_ratio({int(r["seed"]): float(r["final_rmse"]) for r in runs},
                                      {k[2]: v for k, v in lock.items()
                                       if k[:2] == (system, strategy)})
                ticks = sum(int(r["ticks_from_plan"]) + int(r["ticks_fell_back"]) for r in runs)
                fell = sum(int(r["ticks_fell_back"]) for r in runs)
                late = sum(int(r["late_plans"]) for r in runs)
                plans = sum(int(r["plans"]) for r in runs)
                p50 = statistics.median(float(r["plan_ms_p50"]) for r in runs)
                p99 = max(float(r["plan_ms_p99"]) for r in runs)
                lines.append(
                    f"| {system} | {strategy} | {hz:g} Hz | {len(runs)} | {paired['ratio']:.2f} "
                    f"[{paired['low']:.2f}, {paired['high']:.2f}], {paired['wins']} of "
                    f"{paired['seeds']} | {100 * fell / ticks:.1f} % | {late} of {plans} | "
                    f"{p50:.0f} / {p99:.0f} |")
    return "\n".join(lines) + "\n"


def main():
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", help="results directory")
    parser.add_argument("--samples", type=int, default=150)
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--first_seed", type=int, default=1)
    parser.add_argument("--report", nargs="+", help="re-aggregate these directories' runs.csv")
    args = parser.parse_args()
    if args.report:
        rows = []
        for directory in args.report:
            with open(os.path.join(directory, "runs.csv")) as f:
                rows += list(csv.DictReader(f))
        print(report(rows), end="")
        return
    if not args.out:
        parser.error("--out is required")
    os.makedirs(args.out, exist_ok=True)
    work = tempfile.mkdtemp(prefix="excite-realtime-")
    server, address = start_server(work)
    rows = []
    try:
        with open(os.path.join(args.out, "runs.csv"), "w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=FIELDS)
            writer.writeheader()
            # A whole seed at a time.
            for seed in range(args.first_seed, args.first_seed + args.seeds):
                for system, rates in GRID.items():
                    for strategy in STRATEGIES:
                        for hz in [0.0] + rates:
                            row = run_one(address, system, strategy, seed, hz,
                                          args.samples, work)
                            rows.append(row)
                            writer.writerow(row)
                            f.flush()
                            print(f"{system} {strategy} seed {seed} "
                                  f"{'lock-step' if hz == 0 else f'{hz:g} Hz'}: rmse "
                                  f"{row['final_rmse']:.4f}", flush=True)
    finally:
        server.terminate()
        server.wait()
    text = report(rows)
    with open(os.path.join(args.out, "report.md"), "w") as f:
        f.write(text)
    print(text, end="")


if __name__ == "__main__":
    main()
