"""Aggregation of excite-sim trial summaries into the paper's table.

Pure functions on plain data (no subprocesses, no matplotlib), so that they can be
unit-tested on constructed data (tests/bench_paper/aggregate_test.py).

A *trial* is one excite-sim run, given here as a dict with the keys of excite-sim's
--summary JSON (system, strategy, samples, final_rmse, coverage_marginal,
coverage_joint, rmse_history, plan_ms_p50, wall_s) plus "trial" (its index) and
"seed". Failed trials are not trials here: the runner keeps them apart.
"""

import csv
import math
import random

# Columns of results.csv, in order. One row per (system, strategy, trial, samples)
# point of the trial's RMSE history; coverage_marginal, coverage_joint and plan_ms are
# final values of the trial and are written on its last row only (empty elsewhere).
CSV_COLUMNS = [
    "system",
    "strategy",
    "trial",
    "samples",
    "rmse",
    "coverage_marginal",
    "coverage_joint",
    "plan_ms",
]


def mean_std(values):
    """Returns (mean, sample standard deviation, n) of the finite values.

    The standard deviation uses n - 1 (as a spread over trials) and is None for
    fewer than two values; the mean is None for none. Non-finite values and None are
    ignored (a diverged RMSE would otherwise poison the whole cell)."""
    finite = [float(v) for v in values if v is not None and math.isfinite(float(v))]
    n = len(finite)
    if n == 0:
        return None, None, 0
    mean = sum(finite) / n
    if n < 2:
        return mean, None, n
    var = sum((v - mean) ** 2 for v in finite) / (n - 1)
    return mean, math.sqrt(var), n


def decimals_for(value, significant=3):
    """Decimal places that show `value` with `significant` significant digits
    (at least 0, at most 6)."""
    if value is None or value == 0 or not math.isfinite(value):
        return significant - 1
    magnitude = math.floor(math.log10(abs(value)))
    return max(0, min(6, significant - 1 - magnitude))


def format_mean_std(mean, std, n, decimals):
    """'m ± s' with `decimals` places; 'm (1 trial)' when there is no spread;
    'n/a' when there is no value."""
    if mean is None:
        return "n/a"
    if std is None:
        return f"{mean:.{decimals}f} (n={n})"
    return f"{mean:.{decimals}f} ± {std:.{decimals}f}"


def group_trials(trials):
    """{(system, strategy): [trial, ...]} keeping first-seen order of keys and
    sorting each list by trial index."""
    groups = {}
    for t in trials:
        groups.setdefault((t["system"], t["strategy"]), []).append(t)
    for key in groups:
        groups[key].sort(key=lambda t: t["trial"])
    return groups


def final_stats(trials):
    """Per (system, strategy): final RMSE, marginal and joint coverage (fractions)
    and plan_ms_p50, each as {"mean", "std", "n"}; plus "wall_s" and "trials"."""
    stats = {}
    for key, group in group_trials(trials).items():
        entry = {"trials": len(group)}
        for name, field in (
            ("rmse", "final_rmse"),
            ("coverage_marginal", "coverage_marginal"),
            ("coverage_joint", "coverage_joint"),
            ("plan_ms", "plan_ms_p50"),
            ("wall_s", "wall_s"),
        ):
            m, s, n = mean_std([t.get(field) for t in group])
            entry[name] = {"mean": m, "std": s, "n": n}
        stats[key] = entry
    return stats


def history_stats(trials):
    """Per (system, strategy): [(samples, mean, std, n), ...] of the RMSE histories,
    over the trials that have a point at that sample count, sorted by samples."""
    out = {}
    for key, group in group_trials(trials).items():
        by_samples = {}
        for t in group:
            for samples, rmse in t.get("rmse_history") or []:
                by_samples.setdefault(int(samples), []).append(rmse)
        rows = []
        for samples in sorted(by_samples):
            m, s, n = mean_std(by_samples[samples])
            if m is not None:
                rows.append((samples, m, s, n))
        out[key] = rows
    return out


def samples_to_reach(rows, target):
    """The first sample count at which a mean RMSE curve (history_stats rows,
    (samples, mean, std, n) sorted by samples) is at or below `target`; None if it
    never is (or there is no target)."""
    if target is None:
        return None
    for samples, mean, _, _ in rows:
        if mean <= target:
            return samples
    return None


def sample_efficiency(stats, history, systems, strategies, reference="rec"):
    """{system: {strategy: samples or None}}: how many samples each strategy's mean
    RMSE curve needs to reach the reference strategy's final mean RMSE (None: not
    reached, or no reference in that system)."""
    table = {}
    for system in systems:
        entry = stats.get((system, reference))
        target = entry["rmse"]["mean"] if entry is not None else None
        table[system] = {
            strategy: samples_to_reach(history.get((system, strategy), []), target)
            for strategy in strategies
        }
    return table


def sample_efficiency_section(efficiency, systems, strategies, labels,
                              reference_label="rec"):
    """Markdown rows (a title row, then one per strategy) of sample_efficiency():
    the fewest samples in bold, "not reached" where a curve never gets there."""
    lines = ["| **Samples to reach " + reference_label + "'s final RMSE** |" +
             " |" * len(systems)]
    best = {}
    for system in systems:
        reached = {s: v for s, v in efficiency[system].items() if v is not None}
        best[system] = min(reached.values()) if reached else None
    for strategy in strategies:
        row = [labels.get(strategy, strategy)]
        for system in systems:
            value = efficiency[system].get(strategy)
            if value is None:
                row.append("not reached")
            elif value == best[system]:
                row.append(f"**{value}**")
            else:
                row.append(str(value))
        lines.append("| " + " | ".join(row) + " |")
    return lines


def best_in_column(cells, lower_is_better, decimals):
    """Which of `cells` ({row: mean or None}) are best: the lowest (or highest) mean,
    compared as displayed with `decimals` places, so that two cells that read the
    same are both marked. Returns a set of row keys (empty if no cell has a value)."""
    shown = {
        row: round(mean, decimals) for row, mean in cells.items() if mean is not None
    }
    if not shown:
        return set()
    best = min(shown.values()) if lower_is_better else max(shown.values())
    return {row for row, value in shown.items() if value == best}


def _cell_rows(stats, systems, strategies, metric, scale):
    """{system: {strategy: (mean, std, n)}} scaled, None where nothing ran."""
    table = {}
    for system in systems:
        column = {}
        for strategy in strategies:
            entry = stats.get((system, strategy))
            if entry is None or entry[metric]["mean"] is None:
                column[strategy] = (None, None, 0)
            else:
                m = entry[metric]
                column[strategy] = (
                    m["mean"] * scale,
                    None if m["std"] is None else m["std"] * scale,
                    m["n"],
                )
        table[system] = column
    return table


def _section(title, stats, systems, strategies, labels, metric, scale,
             lower_is_better, fixed_decimals=None):
    """Markdown rows of one section of the table (a title row, then one row per
    strategy), with the best cell of each column in bold."""
    cells = _cell_rows(stats, systems, strategies, metric, scale)
    lines = ["| **" + title + "** |" + " |" * len(systems)]
    column_text = {}
    for system in systems:
        column = cells[system]
        if fixed_decimals is not None:
            decimals = fixed_decimals
        else:
            # One precision per column, from its best (smallest) mean: three
            # significant digits there, the same places for every cell.
            means = [c[0] for c in column.values() if c[0] is not None]
            decimals = decimals_for(min(means) if means else None)
        best = best_in_column({s: c[0] for s, c in column.items()}, lower_is_better,
                              decimals)
        text = {}
        for strategy, (m, s, n) in column.items():
            cell = format_mean_std(m, s, n, decimals)
            if strategy in best:
                cell = "**" + cell + "**"
            text[strategy] = cell
        column_text[system] = text
    for strategy in strategies:
        row = [labels.get(strategy, strategy)]
        row += [column_text[system][strategy] for system in systems]
        lines.append("| " + " | ".join(row) + " |")
    return lines


def markdown_table(stats, systems, strategies, system_labels=None,
                   strategy_labels=None, joint=True, history=None, reference="rec"):
    """The paper's Table in markdown: columns are systems, rows strategies, in two
    sections (final RMSE; coverage of the region in percent, marginal), each cell
    mean ± std over the trials, best per column in bold (lowest RMSE, highest
    coverage). With joint=True a third section gives the joint coverage (only
    defined for state_dim <= 4; other columns read n/a). With `history`
    (history_stats) and the reference strategy among `strategies`, a last section
    gives the samples each strategy needs to reach the reference's final RMSE."""
    system_labels = system_labels or {}
    strategy_labels = strategy_labels or {}
    header = "| |" + "".join(f" {system_labels.get(s, s)} |" for s in systems)
    rule = "|---|" + "---|" * len(systems)
    lines = [header, rule]
    lines += _section("Final RMSE", stats, systems, strategies, strategy_labels,
                      "rmse", 1.0, lower_is_better=True)
    lines += _section("Coverage, marginal (% of region)", stats, systems, strategies,
                      strategy_labels, "coverage_marginal", 100.0,
                      lower_is_better=False, fixed_decimals=1)
    if joint:
        lines += _section("Coverage, joint cells (% of region)", stats, systems,
                          strategies, strategy_labels, "coverage_joint", 100.0,
                          lower_is_better=False, fixed_decimals=1)
    if history is not None and reference in strategies:
        lines += sample_efficiency_section(
            sample_efficiency(stats, history, systems, strategies, reference),
            systems, strategies, strategy_labels,
            strategy_labels.get(reference, reference))
    return "\n".join(lines) + "\n"


def trial_count_table(stats, planned, systems, strategies, system_labels=None,
                      strategy_labels=None):
    """Markdown table of succeeded/planned trials per cell ('-' where not planned).

    planned: {(system, strategy): count}."""
    system_labels = system_labels or {}
    strategy_labels = strategy_labels or {}
    header = "| trials |" + "".join(f" {system_labels.get(s, s)} |" for s in systems)
    lines = [header, "|---|" + "---|" * len(systems)]
    for strategy in strategies:
        row = [strategy_labels.get(strategy, strategy)]
        for system in systems:
            p = planned.get((system, strategy), 0)
            done = stats.get((system, strategy), {}).get("trials", 0)
            row.append("-" if p == 0 and done == 0 else f"{done}/{p}")
        lines.append("| " + " | ".join(row) + " |")
    return "\n".join(lines) + "\n"


def paired_ratio(values, reference_values, resamples=10000, level=0.90, seed=0):
    """Paired comparison of two strategies over the same seeds.

    values, reference_values: {seed: metric} (lower is better; positive). Over the
    seeds both have: the geometric mean of value / reference, its `level` paired
    bootstrap interval (seeds resampled with replacement, `resamples` times, from a
    fixed seed), the seeds where value < reference, and their count. None if no
    seed is shared or a value is not positive and finite."""
    seeds = sorted(set(values) & set(reference_values))
    logs = []
    for k in seeds:
        a, b = values[k], reference_values[k]
        if a is None or b is None or not (0 < a < math.inf and 0 < b < math.inf):
            return None
        logs.append(math.log(a / b))
    if not logs:
        return None
    rng = random.Random(seed)
    n = len(logs)
    means = sorted(sum(logs[rng.randrange(n)] for _ in range(n)) / n
                   for _ in range(resamples))
    tail = (1 - level) / 2
    lo = means[int(math.floor(tail * (resamples - 1)))]
    hi = means[int(math.ceil((1 - tail) * (resamples - 1)))]
    return {"ratio": math.exp(sum(logs) / n), "low": math.exp(lo), "high": math.exp(hi),
            "wins": sum(1 for v in logs if v < 0), "seeds": n}


def paired_section(records, systems, strategies, system_labels=None,
                   strategy_labels=None, reference="rec",
                   metrics=(("final_rmse", "final RMSE"),
                            ("rollout_rmse_10", "10-step RMSE"),
                            ("rollout_rmse_30", "30-step RMSE"))):
    """Markdown: per metric, each strategy against `reference` on the same seeds
    (paired_ratio): 'ratio [low, high] wins/seeds'. records: successful trials as
    {"system", "strategy", "seed", "result": summary dict}."""
    system_labels = system_labels or {}
    strategy_labels = strategy_labels or {}
    by_cell = {}
    for r in records:
        by_cell.setdefault((r["system"], r["strategy"]), {})[r["seed"]] = r["result"]
    lines = []
    for key, title in metrics:
        lines += [f"Paired against {reference}, {title}: geometric mean of the ratio over "
                  "the seeds both ran, [90 % paired bootstrap interval], seeds lower.", ""]
        lines.append("| ratio to " + reference + " |"
                     + "".join(f" {system_labels.get(s, s)} |" for s in systems))
        lines.append("|---|" + "---|" * len(systems))
        for strategy in strategies:
            if strategy == reference:
                continue
            row = [strategy_labels.get(strategy, strategy)]
            for system in systems:
                mine = {k: v.get(key) for k, v in by_cell.get((system, strategy), {}).items()}
                ref = {k: v.get(key)
                       for k, v in by_cell.get((system, reference), {}).items()}
                p = paired_ratio(mine, ref)
                row.append("-" if p is None else
                           f"{p['ratio']:.2f} [{p['low']:.2f}, {p['high']:.2f}] "
                           f"{p['wins']}/{p['seeds']}")
            lines.append("| " + " | ".join(row) + " |")
        lines.append("")
    return "\n".join(lines)


def calibration_table(records, systems, strategies, system_labels=None,
                      strategy_labels=None):
    """Markdown: per cell, the mean final NLPD (nats per point and dimension) and
    the mean share of errors inside the 95 % interval, over the successful trials."""
    system_labels = system_labels or {}
    strategy_labels = strategy_labels or {}
    cells = {}
    for r in records:
        res = r["result"]
        cells.setdefault((r["system"], r["strategy"]), []).append(
            (res.get("final_nlpd"), res.get("final_inside_95")))
    lines = ["Calibration at the end: mean NLPD (nats; lower is better) / share of "
             "errors inside the 95 % interval (0.95 when calibrated).", "",
             "| NLPD / inside 95 % |" + "".join(f" {system_labels.get(s, s)} |"
                                               for s in systems),
             "|---|" + "---|" * len(systems)]
    for strategy in strategies:
        row = [strategy_labels.get(strategy, strategy)]
        for system in systems:
            pairs = [(a, b) for a, b in cells.get((system, strategy), [])
                     if a is not None and b is not None]
            if not pairs:
                row.append("-")
                continue
            row.append(f"{sum(a for a, _ in pairs) / len(pairs):.2f} / "
                       f"{sum(b for _, b in pairs) / len(pairs):.2f}")
        lines.append("| " + " | ".join(row) + " |")
    return "\n".join(lines) + "\n"


def _csv_number(value):
    if value is None:
        return ""
    value = float(value)
    if not math.isfinite(value):
        return ""
    return repr(value)


def csv_rows(trials):
    """Rows (lists of strings, CSV_COLUMNS order) for the trials: one per RMSE
    history point; the final coverage and plan_ms_p50 on the trial's last row only.
    A trial without history gets one row at its final sample count."""
    rows = []
    for t in sorted(trials, key=lambda t: (t["system"], t["strategy"], t["trial"])):
        history = list(t.get("rmse_history") or [])
        if not history:
            history = [[t.get("samples", 0), t.get("final_rmse")]]
        for i, (samples, rmse) in enumerate(history):
            last = i == len(history) - 1
            rows.append([
                t["system"],
                t["strategy"],
                str(t["trial"]),
                str(int(samples)),
                _csv_number(rmse),
                _csv_number(t.get("coverage_marginal")) if last else "",
                _csv_number(t.get("coverage_joint")) if last else "",
                _csv_number(t.get("plan_ms_p50")) if last else "",
            ])
    return rows


def write_csv(path, trials):
    """Writes results.csv (header CSV_COLUMNS, then csv_rows(trials))."""
    with open(path, "w", newline="", encoding="utf-8") as f:
        writer = csv.writer(f, lineterminator="\n")
        writer.writerow(CSV_COLUMNS)
        writer.writerows(csv_rows(trials))


def read_csv(path):
    """Reads results.csv back into trials (rmse_history, final values), the inverse
    of write_csv up to float formatting; used by the output check."""
    trials = {}
    with open(path, newline="", encoding="utf-8") as f:
        reader = csv.DictReader(f)
        if reader.fieldnames != CSV_COLUMNS:
            raise ValueError(f"{path}: columns {reader.fieldnames}, expected {CSV_COLUMNS}")
        for row in reader:
            key = (row["system"], row["strategy"], int(row["trial"]))
            t = trials.setdefault(key, {
                "system": row["system"], "strategy": row["strategy"],
                "trial": int(row["trial"]), "rmse_history": [],
            })
            rmse = float(row["rmse"]) if row["rmse"] else None
            t["rmse_history"].append([int(row["samples"]), rmse])
            t["samples"] = int(row["samples"])
            t["final_rmse"] = rmse
            for name, field in (("coverage_marginal", "coverage_marginal"),
                                ("coverage_joint", "coverage_joint"),
                                ("plan_ms", "plan_ms_p50")):
                if row[name]:
                    t[field] = float(row[name])
    return list(trials.values())


def variant_section(variant_rows, reference_rows, metrics, system_labels=None):
    """Markdown: one row per system (in the order first seen), one column per metric:
    a variant's trials against a reference run's on the same seeds (paired_ratio)
    as 'ratio [low, high] lower/seeds'. Rows are trials.csv rows (dicts of strings);
    only status "ok" counts."""
    system_labels = system_labels or {}

    def number(text):
        return float(text) if text not in (None, "") else None

    def by_system(rows):
        out = {}
        for r in rows:
            if r.get("status") == "ok":
                out.setdefault(r["system"], {})[int(r["seed"])] = r
        return out

    mine, ref = by_system(variant_rows), by_system(reference_rows)
    systems = [s for s in dict.fromkeys(r["system"] for r in variant_rows) if s in ref]
    lines = ["| system |" + "".join(f" {m} |" for m in metrics),
             "|---|" + "---|" * len(metrics)]
    for system in systems:
        cells = []
        for metric in metrics:
            p = paired_ratio({k: number(r.get(metric)) for k, r in mine[system].items()},
                             {k: number(r.get(metric)) for k, r in ref[system].items()})
            cells.append("-" if p is None else
                         f"{p['ratio']:.3f} [{p['low']:.3f}, {p['high']:.3f}] "
                         f"{p['wins']}/{p['seeds']}")
        lines.append(f"| {system_labels.get(system, system)} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"
