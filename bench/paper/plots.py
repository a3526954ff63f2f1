"""PNG plots of a benchmark run (matplotlib, Agg backend: no display needed).

rmse_<system>.png  RMSE over samples, mean ± std band per strategy (the paper's Figure)
rmse_all.png       the same for every system on one page
coverage.png       final marginal coverage, mean ± std, grouped bars per system
"""

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (after use())

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
    "uniform": "#000000",
}


def _color(strategy, index):
    # A strategy without a colour of its own takes one no listed strategy uses.
    spare = ["#aec7e8", "#ffbb78", "#98df8a", "#c5b0d5"]
    return COLORS.get(strategy, spare[index % len(spare)])


def _draw_rmse(ax, history, system, strategies, strategy_labels, title):
    drawn = 0
    for i, strategy in enumerate(strategies):
        rows = history.get((system, strategy))
        if not rows:
            continue
        x = [r[0] for r in rows]
        mean = [r[1] for r in rows]
        std = [r[2] if r[2] is not None else 0.0 for r in rows]
        color = _color(strategy, i)
        ax.plot(x, mean, color=color, lw=1.6,
                label=strategy_labels.get(strategy, strategy))
        ax.fill_between(x, [m - s for m, s in zip(mean, std)],
                        [m + s for m, s in zip(mean, std)], color=color, alpha=0.18,
                        lw=0)
        drawn += 1
    ax.set_title(title)
    ax.set_xlabel("samples")
    ax.set_ylabel("RMSE")
    ax.grid(True, alpha=0.3)
    return drawn


def plot_rmse_system(path, history, system, strategies, system_label,
                     strategy_labels, subtitle=""):
    """One system's RMSE over samples; returns False if there was nothing to draw."""
    fig, ax = plt.subplots(figsize=(6.4, 4.0), dpi=100)
    title = system_label + (f" ({subtitle})" if subtitle else "")
    drawn = _draw_rmse(ax, history, system, strategies, strategy_labels, title)
    if drawn:
        ax.legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(path)
    plt.close(fig)
    return drawn > 0


def plot_rmse_all(path, history, systems, strategies, system_labels,
                  strategy_labels, subtitle=""):
    """Every system's RMSE over samples on one page (3 x 2 grid, as the paper)."""
    systems = [s for s in systems
               if any(history.get((s, st)) for st in strategies)]
    if not systems:
        return False
    cols = 2 if len(systems) > 1 else 1
    rows = (len(systems) + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(5.2 * cols, 3.4 * rows), dpi=90,
                             squeeze=False)
    for ax, system in zip(axes.flat, systems):
        _draw_rmse(ax, history, system, strategies, strategy_labels,
                   system_labels.get(system, system))
    handles, names = [], []
    for ax in axes.flat[:len(systems)]:
        for h, n in zip(*ax.get_legend_handles_labels()):
            if n not in names:
                handles.append(h)
                names.append(n)
    spare = list(axes.flat[len(systems):])
    for ax in spare:
        ax.axis("off")
    if spare:  # the legend in the empty panel, as in the paper's Figure
        spare[0].legend(handles, names, loc="center", fontsize=10, title="strategy")
    else:
        axes.flat[0].legend(handles, names, fontsize=8)
    fig.suptitle("RMSE over samples (mean ± std)" + (f" — {subtitle}" if subtitle else ""))
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return True


def plot_coverage(path, stats, systems, strategies, system_labels, strategy_labels,
                  subtitle=""):
    """Grouped bars: final marginal coverage (%) per system, one bar per strategy,
    error bars = std over trials."""
    systems = [s for s in systems if any((s, st) in stats for st in strategies)]
    present = [st for st in strategies if any((s, st) in stats for s in systems)]
    if not systems or not present:
        return False
    fig, ax = plt.subplots(figsize=(max(6.4, 1.6 * len(systems) + 2), 4.0), dpi=100)
    width = 0.8 / len(present)
    for i, strategy in enumerate(present):
        xs, heights, errs = [], [], []
        for j, system in enumerate(systems):
            entry = stats.get((system, strategy))
            if entry is None or entry["coverage_marginal"]["mean"] is None:
                continue
            c = entry["coverage_marginal"]
            xs.append(j - 0.4 + width * (i + 0.5))
            heights.append(100.0 * c["mean"])
            errs.append(100.0 * (c["std"] or 0.0))
        ax.bar(xs, heights, width, yerr=errs, capsize=2,
               color=_color(strategy, strategies.index(strategy)),
               label=strategy_labels.get(strategy, strategy))
    ax.set_xticks(range(len(systems)))
    ax.set_xticklabels([system_labels.get(s, s) for s in systems])
    ax.set_ylabel("coverage, marginal (% of region)")
    ax.set_ylim(0, 105)
    ax.set_title("Final coverage (mean ± std)" + (f" — {subtitle}" if subtitle else ""))
    ax.grid(True, axis="y", alpha=0.3)
    ax.legend(fontsize=8, ncol=min(4, len(present)))
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return True
