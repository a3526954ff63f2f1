"""Checks that a results directory of bench/paper/run.py is complete and well formed.

Used by `run.py --ci` and by the ctest check (tests/bench_paper). Returns a list of
problems (empty when all is well) rather than raising, so that every problem is
reported at once.
"""

import math
import os

import aggregate

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def check_png(path):
    """'' if `path` is a non-empty file that starts with the PNG signature and has an
    IHDR chunk with a non-zero size; otherwise what is wrong."""
    if not os.path.isfile(path):
        return f"{path}: missing"
    with open(path, "rb") as f:
        head = f.read(24)
    if len(head) < 24:
        return f"{path}: too short for a PNG ({len(head)} bytes)"
    if head[:8] != PNG_SIGNATURE:
        return f"{path}: not a PNG (bad signature)"
    if head[12:16] != b"IHDR":
        return f"{path}: no IHDR chunk"
    width = int.from_bytes(head[16:20], "big")
    height = int.from_bytes(head[20:24], "big")
    if width == 0 or height == 0:
        return f"{path}: empty image {width}x{height}"
    return ""


def check_csv(path, expected_pairs):
    """Problems of results.csv: columns, parseable numbers, every expected
    (system, strategy) pair present, samples increasing within a trial, final
    coverage on each trial's last row."""
    problems = []
    try:
        trials = aggregate.read_csv(path)
    except (OSError, ValueError, KeyError) as e:
        return [f"{path}: {e}"]
    seen = {(t["system"], t["strategy"]) for t in trials}
    for pair in expected_pairs:
        if pair not in seen:
            problems.append(f"{path}: no rows for {pair[0]}/{pair[1]}")
    for t in trials:
        name = f"{path}: {t['system']}/{t['strategy']} trial {t['trial']}"
        samples = [s for s, _ in t["rmse_history"]]
        if samples != sorted(samples) or len(set(samples)) != len(samples):
            problems.append(f"{name}: samples not increasing {samples}")
        rmse = t.get("final_rmse")
        if rmse is None or not math.isfinite(rmse) or rmse < 0:
            problems.append(f"{name}: final rmse {rmse}")
        cov = t.get("coverage_marginal")
        if cov is None or not 0.0 <= cov <= 1.0:
            problems.append(f"{name}: coverage_marginal {cov} not in [0, 1]")
    return problems


def check_table(path, systems, strategies, system_labels, strategy_labels):
    """Problems of table.md: a header naming every system (by its label), and for
    each strategy a row in each section with one cell per system."""
    if not os.path.isfile(path):
        return [f"{path}: missing"]
    with open(path, encoding="utf-8") as f:
        lines = [line.rstrip("\n") for line in f]
    problems = []
    rows = [line for line in lines if line.startswith("|")]
    if not rows:
        return [f"{path}: no table"]
    header = rows[0]
    header_cells = [c.strip() for c in header.strip().strip("|").split("|")]
    for system in systems:
        if system_labels.get(system, system) not in header_cells:
            problems.append(f"{path}: header lacks {system}: {header}")
    ncells = len(systems) + 1
    for strategy in strategies:
        label = strategy_labels.get(strategy, strategy)
        found = [r for r in rows if r.split("|")[1].strip() == label]
        # Final RMSE, marginal coverage, joint coverage (+ the trial-count table).
        if len(found) < 3:
            problems.append(f"{path}: {len(found)} rows for {label}, expected >= 3")
        for r in found:
            cells = r.strip().strip("|").split("|")
            if len(cells) != ncells:
                problems.append(f"{path}: row has {len(cells)} cells, expected "
                                f"{ncells}: {r}")
    return problems


def check_outputs(out_dir, expected_pairs, system_labels=None, strategy_labels=None):
    """All problems of a results directory. expected_pairs: (system, strategy) pairs
    that must have at least one successful trial."""
    system_labels = system_labels or {}
    strategy_labels = strategy_labels or {}
    problems = []
    systems = list(dict.fromkeys(s for s, _ in expected_pairs))
    strategies = list(dict.fromkeys(st for _, st in expected_pairs))
    problems += check_csv(os.path.join(out_dir, "results.csv"), expected_pairs)
    problems += check_table(os.path.join(out_dir, "table.md"), systems, strategies,
                            system_labels, strategy_labels)
    pngs = [f"rmse_{s}.png" for s in systems] + ["rmse_all.png", "coverage.png"]
    for name in pngs:
        problem = check_png(os.path.join(out_dir, name))
        if problem:
            problems.append(problem)
    for system, strategy in expected_pairs:
        d = os.path.join(out_dir, "trials", system, strategy)
        if not os.path.isdir(d) or not any(n.endswith(".json") for n in os.listdir(d)):
            problems.append(f"{d}: no trial summary")
        elif not any(n.endswith(".log") for n in os.listdir(d)):
            problems.append(f"{d}: no excite-sim log")
    return problems
