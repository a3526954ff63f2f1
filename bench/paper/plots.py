"""PNG plots of a benchmark run (matplotlib, Agg backend: no display needed).

rmse_<system>.png  RMSE over samples of one system (the paper's Figure, one panel)
rmse_all.png       one panel per system on one page
coverage.png       final marginal coverage, mean ± std, grouped bars per system

Made to be read, not only to exist (issue 12):

- Highlighting rule, per panel: the HIGHLIGHT (3) strategies with the lowest mean
  RMSE at the last point of their curve are drawn bold with their ± std band (sample
  std over the trials; none for a single trial), and so is any other whose final
  value reads the same as the third's at 3 significant digits (as the legend shows
  it); every other strategy is drawn thin and faded, without a band. Reference rows
  (REFERENCES: `uniform`, the idealised design no plant can follow) are never
  ranked: a dashed dark line, no band. Exact ties in the ranking are broken by the
  order of `strategies`, so the choice is deterministic.
- Log scale rule, per panel: the y axis is logarithmic when the mean curves drawn in
  the panel (references included) span more than LOG_DECADES (0.75) decades,
  max / min > 10^0.75 = 5.6; otherwise linear from 0. Either way the y limits come
  from the mean curves (first points included) and the highlighted curves' ± std
  bands, so no band is cut at the top or bottom of the axes; never from the last
  stretch alone, so trial-to-trial noise is not magnified. On a log axis a band
  whose lower end is at or below 0 cannot be drawn: it runs to the bottom edge.
- Every legend entry carries the number of trials behind the curve, "rec (n=3)"
  ("n=2-3" when trials have histories of different lengths) and its final mean
  RMSE; the legend is sorted by that final value and sits outside the axes.
- Fixed colour (COLORS) and marker (MARKERS) per strategy in every plot; DPI (150)
  for every PNG.
"""

import math
import textwrap

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (after use())
from matplotlib import ticker  # noqa: E402

DPI = 150
HIGHLIGHT = 3
LOG_DECADES = 0.75
REFERENCES = ("uniform",)

# One colour per strategy, the same in every plot.
COLORS = {
    "prbs": "#1f77b4",
    "chirp": "#ff7f0e",
    "sep": "#9467bd",
    "rec": "#2ca02c",
    "pa": "#d62728",
    "greedy": "#8c564b",
    "random": "#7f7f7f",
    "mi": "#e377c2",
    "roi": "#17becf",
    "optimistic": "#bcbd22",
    "auto": "#9edae5",
    "uniform": "#000000",
}

# One marker per strategy (drawn every few points), so that lines can be told apart
# without colour too.
MARKERS = {
    "prbs": "s",
    "chirp": "v",
    "sep": "D",
    "rec": "o",
    "pa": "^",
    "greedy": "P",
    "random": "x",
    "mi": "*",
    "roi": "X",
    "optimistic": "d",
    "auto": "h",
    "uniform": "",
}


def _color(strategy, index):
    # A strategy without a colour of its own takes one no listed strategy uses.
    spare = ["#aec7e8", "#ffbb78", "#98df8a", "#c5b0d5"]
    return COLORS.get(strategy, spare[index % len(spare)])


def _marker(strategy):
    return MARKERS.get(strategy, ".")


def trial_count_text(n_min, n_max):
    """'n=3', or 'n=2-3' when the points of a curve rest on different counts."""
    return f"n={n_max}" if n_min == n_max else f"n={n_min}-{n_max}"


def legend_label(label, n_min, n_max, final):
    """A legend entry: 'rec (n=3): 0.215' (the final mean RMSE, 3 significant
    digits)."""
    return f"{label} ({trial_count_text(n_min, n_max)}): {final:.3g}"


def _shown(value):
    """A final mean RMSE as the legend shows it (3 significant digits)."""
    return float(f"{value:.3g}")


def _highlighted(ranked, curves):
    """The first HIGHLIGHT of `ranked`, plus any later one whose final value reads
    the same as the last of those (a tie as displayed is not broken by order)."""
    if len(ranked) <= HIGHLIGHT:
        return list(ranked)
    final = {c["strategy"]: c["final"] for c in curves}
    cut = _shown(final[ranked[HIGHLIGHT - 1]])
    return ranked[:HIGHLIGHT] + [s for s in ranked[HIGHLIGHT:] if _shown(final[s]) <= cut]


def panel_plan(history, system, strategies):
    """What one RMSE panel shows, decided without matplotlib (tested on its own).

    history: aggregate.history_stats() ({(system, strategy): [(samples, mean, std,
    n), ...]}). Returns None when nothing is drawn, else a dict:
      curves       [{strategy, index, rows, final, n_min, n_max}] in `strategies`
                   order, those with at least one point
      ranked       non-reference strategies, lowest final mean RMSE first (ties:
                   `strategies` order)
      highlighted  the first HIGHLIGHT of `ranked`, plus any that ties the last of
                   them as displayed (3 significant digits)
      references   the reference strategies drawn
      order        legend order: ranked, then references
      log          True when max / min of the mean curves > 10^LOG_DECADES
      ylim         (low, high) over the means and the highlighted bands: log: min /
                   1.15 .. max * 1.15 (band ends <= 0 left out); linear: 0 .. max * 1.05
      xmax         the largest sample count
    """
    curves = []
    for i, strategy in enumerate(strategies):
        rows = [r for r in history.get((system, strategy)) or []
                if r[1] is not None and math.isfinite(r[1])]
        if not rows:
            continue
        ns = [r[3] for r in rows]
        curves.append({"strategy": strategy, "index": i, "rows": rows,
                       "final": rows[-1][1], "n_min": min(ns), "n_max": max(ns)})
    if not curves:
        return None
    ranked = [c["strategy"] for c in sorted(
        (c for c in curves if c["strategy"] not in REFERENCES),
        key=lambda c: (c["final"], c["index"]))]
    references = [c["strategy"] for c in curves if c["strategy"] in REFERENCES]
    means = [r[1] for c in curves for r in c["rows"]]
    low, high = min(means), max(means)
    log = low > 0 and math.log10(high / low) > LOG_DECADES
    highlighted = _highlighted(ranked, curves)
    bands = [(r[1] - r[2], r[1] + r[2]) for c in curves if c["strategy"] in highlighted
             for r in c["rows"] if r[2] is not None and math.isfinite(r[2])]
    high = max([high] + [b[1] for b in bands])
    if log:
        low = min([low] + [b[0] for b in bands if b[0] > 0])
        ylim = (low / 1.15, high * 1.15)
    else:
        ylim = (0.0, high * 1.05 if high > 0 else 1.0)
    return {
        "curves": curves,
        "ranked": ranked,
        "highlighted": highlighted,
        "references": references,
        "order": ranked + references,
        "log": log,
        "ylim": ylim,
        "xmax": max(r[0] for c in curves for r in c["rows"]),
    }


def draw_rmse_panel(ax, history, system, strategies, strategy_labels, title,
                    legend=True):
    """Draws one system's RMSE curves on `ax` by the rules of this module's
    docstring; returns panel_plan()'s dict (None if there was nothing to draw)."""
    plan = panel_plan(history, system, strategies)
    ax.set_title(title)
    if plan is None:
        return None
    by_strategy = {c["strategy"]: c for c in plan["curves"]}
    low = plan["ylim"][0]
    handles = {}
    for strategy in plan["order"]:
        c = by_strategy[strategy]
        x = [r[0] for r in c["rows"]]
        mean = [r[1] for r in c["rows"]]
        color = _color(strategy, c["index"])
        label = legend_label(strategy_labels.get(strategy, strategy), c["n_min"],
                             c["n_max"], c["final"])
        every = max(1, len(x) // 6)
        if strategy in REFERENCES:
            line, = ax.plot(x, mean, color=color, lw=1.4, ls="--", alpha=0.8,
                            label=label, zorder=2)
        elif strategy in plan["highlighted"]:
            line, = ax.plot(x, mean, color=color, lw=2.4, marker=_marker(strategy),
                            markevery=every, ms=6, label=label, zorder=4)
            std = [r[2] for r in c["rows"]]
            if any(s is not None for s in std):
                std = [s or 0.0 for s in std]
                lower = [m - s for m, s in zip(mean, std)]
                if plan["log"]:  # m - s can be <= 0: keep the band on the axes
                    lower = [max(v, low) for v in lower]
                ax.fill_between(x, lower, [m + s for m, s in zip(mean, std)],
                                color=color, alpha=0.16, lw=0, zorder=3)
        else:
            line, = ax.plot(x, mean, color=color, lw=1.0, alpha=0.45,
                            marker=_marker(strategy), markevery=every, ms=3.5,
                            label=label, zorder=1)
        handles[strategy] = line
    if plan["log"]:
        ax.set_yscale("log")
        ax.yaxis.set_major_locator(ticker.LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
        ax.yaxis.set_major_formatter(ticker.FuncFormatter(lambda v, _: f"{v:g}"))
        ax.yaxis.set_minor_formatter(ticker.NullFormatter())
        ax.set_ylabel("RMSE, all state dims (log scale)")
    else:
        ax.set_ylabel("RMSE, all state dims")
    ax.set_ylim(*plan["ylim"])
    ax.set_xlim(0, plan["xmax"])
    ax.set_xlabel("samples")
    ax.grid(True, which="major", alpha=0.3)
    if legend:
        ax.legend([handles[s] for s in plan["order"]],
                  [handles[s].get_label() for s in plan["order"]],
                  loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0,
                  fontsize=8, title="final mean RMSE", title_fontsize=8,
                  frameon=False)
    return plan


def rule_text(with_reference):
    """The figure's rule; the dashed reference only when one is drawn."""
    reference = ("dashed: uniform (ideal), the reference no plant can follow. "
                 if with_reference else "")
    return (f"Bold, with ± std band: the {HIGHLIGHT} strategies with the lowest final "
            "mean RMSE in the panel (and any that reads the same as the third); "
            f"thin: the others; {reference}n = trials. RMSE pools every state "
            "dimension in its own units (e.g. rad and rad/s together). Log y axis "
            f"where the mean curves span more than {LOG_DECADES:g} decades, else "
            "linear from 0.")


def plot_rmse_system(path, history, system, strategies, system_label,
                     strategy_labels, subtitle=""):
    """One system's RMSE over samples; returns False if there was nothing to draw."""
    fig, ax = plt.subplots(figsize=(8.0, 4.2), layout="constrained")
    title = system_label + (f" ({subtitle})" if subtitle else "")
    plan = draw_rmse_panel(ax, history, system, strategies, strategy_labels, title)
    if plan is not None:
        fig.savefig(path, dpi=DPI)
    plt.close(fig)
    return plan is not None


def plot_rmse_all(path, history, systems, strategies, system_labels,
                  strategy_labels, subtitle=""):
    """One panel per system, two columns; each panel with its own legend (trial
    counts differ per system); a spare panel holds the rules."""
    systems = [s for s in systems
               if any(history.get((s, st)) for st in strategies)]
    if not systems:
        return False
    cols = 2 if len(systems) > 1 else 1
    rows = (len(systems) + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(7.6 * cols, 3.6 * rows + 0.6),
                             squeeze=False, layout="constrained")
    for ax, system in zip(axes.flat, systems):
        draw_rmse_panel(ax, history, system, strategies, strategy_labels,
                        system_labels.get(system, system))
    spare = list(axes.flat[len(systems):])
    for ax in spare:
        ax.axis("off")
    drawn_reference = any(history.get((s, r)) for s in systems for r in REFERENCES
                          if r in strategies)
    rule = textwrap.fill(rule_text(drawn_reference), 60 if spare else 160)
    if spare:
        spare[0].text(0.0, 0.5, rule, va="center", ha="left", fontsize=9,
                      transform=spare[0].transAxes)
    else:
        fig.supxlabel(rule, fontsize=8)
    fig.suptitle("RMSE over samples, mean over trials"
                 + (f" — {subtitle}" if subtitle else ""))
    fig.savefig(path, dpi=DPI)
    plt.close(fig)
    return True


def plot_coverage(path, stats, systems, strategies, system_labels, strategy_labels,
                  subtitle=""):
    """Grouped bars: final marginal coverage (%) per system, one bar per strategy,
    error bars = std over trials, each bar's trial count written at its foot."""
    systems = [s for s in systems if any((s, st) in stats for st in strategies)]
    present = [st for st in strategies if any((s, st) in stats for s in systems)]
    if not systems or not present:
        return False
    fig, ax = plt.subplots(figsize=(max(7.5, 1.7 * len(systems) + 3), 4.2),
                           layout="constrained")
    width = 0.8 / len(present)
    for i, strategy in enumerate(present):
        xs, heights, errs, counts = [], [], [], []
        for j, system in enumerate(systems):
            entry = stats.get((system, strategy))
            if entry is None or entry["coverage_marginal"]["mean"] is None:
                continue
            c = entry["coverage_marginal"]
            xs.append(j - 0.4 + width * (i + 0.5))
            height = 100.0 * c["mean"]
            spread = 100.0 * (c["std"] or 0.0)
            heights.append(height)
            # Clipped to [0, 100] %: a share cannot leave it.
            errs.append((min(spread, height), min(spread, 100.0 - height)))
            counts.append(c["n"])
        n_text = trial_count_text(min(counts), max(counts)) if counts else "n=0"
        yerr = [[e[0] for e in errs], [e[1] for e in errs]] if errs else None
        ax.bar(xs, heights, width, yerr=yerr, capsize=2,
               color=_color(strategy, strategies.index(strategy)),
               edgecolor="white", lw=0.5,
               label=f"{strategy_labels.get(strategy, strategy)} ({n_text})")
    ax.set_xticks(range(len(systems)))
    ax.set_xticklabels([system_labels.get(s, s) for s in systems])
    ax.set_ylabel("coverage, marginal (% of region)")
    ax.set_ylim(0, 105)
    ax.set_title("Final coverage (mean ± std over n trials)"
                 + (f" — {subtitle}" if subtitle else ""))
    ax.grid(True, axis="y", alpha=0.3)
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0,
              fontsize=8, frameon=False)
    fig.savefig(path, dpi=DPI)
    plt.close(fig)
    return True


def png_dpi(path):
    """The resolution a PNG declares (its pHYs chunk) in dots per inch, rounded;
    None without one. Used by the tests."""
    with open(path, "rb") as f:
        data = f.read()
    pos = 8
    while pos + 8 <= len(data):
        length = int.from_bytes(data[pos:pos + 4], "big")
        kind = data[pos + 4:pos + 8]
        if kind == b"pHYs":
            body = data[pos + 8:pos + 8 + length]
            per_metre = int.from_bytes(body[0:4], "big")
            return round(per_metre * 0.0254) if body[8] == 1 else None
        if kind == b"IDAT":
            return None
        pos += 12 + length
    return None
