"""Unit tests of bench/paper's aggregation, CSV writing, output checks, plot rules
and combining of runs, on constructed data (no server, no simulator).

  /usr/bin/python3 tests/bench_paper/aggregate_test.py [--bench_dir bench/paper]
"""

import csv
import math
import os
import sys
import tempfile
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
BENCH_DIR = os.path.join(HERE, "..", "..", "bench", "paper")
if "--bench_dir" in sys.argv:
    i = sys.argv.index("--bench_dir")
    BENCH_DIR = sys.argv[i + 1]
    del sys.argv[i:i + 2]
sys.path.insert(0, os.path.abspath(BENCH_DIR))

import aggregate  # noqa: E402
import check  # noqa: E402


def trial(system, strategy, index, history, cov=0.5, joint=None, plan=10.0, wall=1.0):
    return {
        "system": system, "strategy": strategy, "trial": index, "seed": index,
        "samples": history[-1][0] if history else 0,
        "final_rmse": history[-1][1] if history else None,
        "coverage_marginal": cov, "coverage_joint": joint,
        "rmse_history": history, "plan_ms_p50": plan, "wall_s": wall,
    }


class PairedTest(unittest.TestCase):
    def test_geometric_mean_interval_and_wins(self):
        p = aggregate.paired_ratio({0: 1.0, 1: 4.0, 7: 9.0}, {0: 2.0, 1: 2.0, 3: 1.0})
        self.assertEqual(p["seeds"], 2)  # seeds 7 and 3 are not shared
        self.assertAlmostEqual(p["ratio"], 1.0)  # sqrt(0.5 * 2)
        self.assertEqual(p["wins"], 1)
        # Resampling two seeds: means of {log 0.5, log 2} pairs, 0.5 to 2.
        self.assertAlmostEqual(p["low"], 0.5)
        self.assertAlmostEqual(p["high"], 2.0)

    def test_identical_runs_and_bad_values(self):
        p = aggregate.paired_ratio({0: 0.3, 1: 0.2}, {0: 0.3, 1: 0.2})
        self.assertEqual((p["ratio"], p["low"], p["high"], p["wins"]), (1.0, 1.0, 1.0, 0))
        self.assertIsNone(aggregate.paired_ratio({0: 0.0}, {0: 1.0}))
        self.assertIsNone(aggregate.paired_ratio({0: None}, {0: 1.0}))
        self.assertIsNone(aggregate.paired_ratio({0: 1.0}, {1: 1.0}))

    def test_variant_section_pairs_two_runs_by_system_and_seed(self):
        def row(system, seed, rmse, status="ok"):
            return {"system": system, "seed": str(seed), "status": status,
                    "final_rmse": str(rmse), "midway_rmse": ""}
        variant = [row("pendulum", 0, 1.0), row("pendulum", 1, 4.0),
                   row("pendulum", 2, 0.1, status="failed"), row("dipc", 0, 3.0)]
        reference = [row("pendulum", 0, 2.0), row("pendulum", 1, 2.0),
                     row("pendulum", 2, 1.0), row("dipc", 0, 1.0)]
        text = aggregate.variant_section(variant, reference, ["final_rmse", "midway_rmse"])
        lines = text.splitlines()
        self.assertEqual(lines[0], "| system | final_rmse | midway_rmse |")
        # The failed trial is left out: seeds 0 and 1, ratios 0.5 and 2.
        self.assertEqual(lines[2], "| pendulum | 1.000 [0.500, 2.000] 1/2 | - |")
        self.assertEqual(lines[3], "| dipc | 3.000 [3.000, 3.000] 0/1 | - |")

    def test_sections(self):
        records = [{"system": "pendulum", "strategy": st, "seed": k,
                    "result": {"final_rmse": v, "rollout_rmse_10": v,
                               "rollout_rmse_30": None, "final_nlpd": -1.0 - k,
                               "final_inside_95": 0.9}}
                   for st, values in (("rec", [0.2, 0.4]), ("pa", [0.1, 0.2]))
                   for k, v in enumerate(values)]
        text = aggregate.paired_section(records, ["pendulum"], ["rec", "pa"])
        self.assertIn("| pa | 0.50 [0.50, 0.50] 2/2 |", text)
        self.assertIn("| pa | - |", text)  # no 30-step errors
        table = aggregate.calibration_table(records, ["pendulum"], ["rec", "pa"])
        self.assertIn("| rec | -1.50 / 0.90 |", table)


class MeanStdTest(unittest.TestCase):
    def test_known_values(self):
        m, s, n = aggregate.mean_std([2.0, 4.0, 4.0, 4.0, 5.0, 5.0, 7.0, 9.0])
        self.assertEqual(n, 8)
        self.assertAlmostEqual(m, 5.0)
        # Sample (n - 1) standard deviation: sqrt(32 / 7).
        self.assertAlmostEqual(s, math.sqrt(32.0 / 7.0))

    def test_one_value_has_no_spread(self):
        self.assertEqual(aggregate.mean_std([3.0]), (3.0, None, 1))

    def test_empty_and_non_finite_are_ignored(self):
        self.assertEqual(aggregate.mean_std([]), (None, None, 0))
        m, s, n = aggregate.mean_std([1.0, None, float("nan"), float("inf"), 3.0])
        self.assertEqual((m, n), (2.0, 2))
        self.assertAlmostEqual(s, math.sqrt(2.0))


class FormatTest(unittest.TestCase):
    def test_decimals_three_significant_digits(self):
        self.assertEqual(aggregate.decimals_for(0.1534), 3)
        self.assertEqual(aggregate.decimals_for(1.4), 2)
        self.assertEqual(aggregate.decimals_for(12.0), 1)
        self.assertEqual(aggregate.decimals_for(345.0), 0)
        self.assertEqual(aggregate.decimals_for(None), 2)

    def test_cells(self):
        self.assertEqual(aggregate.format_mean_std(1.234, 0.5, 3, 2), "1.23 ± 0.50")
        self.assertEqual(aggregate.format_mean_std(1.234, None, 1, 2), "1.23 (n=1)")
        self.assertEqual(aggregate.format_mean_std(None, None, 0, 2), "n/a")


class StatsTest(unittest.TestCase):
    def setUp(self):
        self.trials = [
            trial("pendulum", "rec", 1, [[10, 1.0], [20, 0.4]], cov=0.8, joint=0.3),
            trial("pendulum", "rec", 0, [[10, 3.0], [20, 0.2]], cov=0.6, joint=0.1),
            trial("pendulum", "pa", 0, [[10, 2.0], [20, 1.0]], cov=0.5, joint=None),
            trial("dipc", "rec", 0, [[10, 5.0]], cov=0.2),
        ]

    def test_final_stats(self):
        stats = aggregate.final_stats(self.trials)
        rec = stats[("pendulum", "rec")]
        self.assertEqual(rec["trials"], 2)
        self.assertAlmostEqual(rec["rmse"]["mean"], 0.3)
        self.assertAlmostEqual(rec["rmse"]["std"], math.sqrt(0.02))
        self.assertAlmostEqual(rec["coverage_marginal"]["mean"], 0.7)
        self.assertAlmostEqual(rec["coverage_joint"]["mean"], 0.2)
        self.assertIsNone(stats[("pendulum", "pa")]["coverage_joint"]["mean"])
        self.assertEqual(stats[("dipc", "rec")]["rmse"]["n"], 1)

    def test_history_stats_align_on_samples(self):
        history = aggregate.history_stats(self.trials)
        rows = history[("pendulum", "rec")]
        self.assertEqual([r[0] for r in rows], [10, 20])
        self.assertAlmostEqual(rows[0][1], 2.0)
        self.assertAlmostEqual(rows[0][2], math.sqrt(2.0))
        self.assertEqual(rows[1][3], 2)

    def test_history_with_unequal_lengths(self):
        trials = [trial("p", "rec", 0, [[10, 1.0], [20, 2.0]]),
                  trial("p", "rec", 1, [[10, 3.0]])]
        rows = aggregate.history_stats(trials)[("p", "rec")]
        self.assertEqual(rows[0][3], 2)
        self.assertEqual(rows[1], (20, 2.0, None, 1))


class SampleEfficiencyTest(unittest.TestCase):
    def setUp(self):
        self.trials = [
            trial("p", "rec", 0, [[10, 2.0], [20, 1.0], [30, 0.5]]),
            trial("p", "rec", 1, [[10, 2.0], [20, 1.0], [30, 0.7]]),
            trial("p", "mi", 0, [[10, 1.5], [20, 0.6], [30, 0.4]]),
            trial("p", "prbs", 0, [[10, 3.0], [20, 2.0], [30, 0.61]]),
            trial("q", "mi", 0, [[10, 1.0]]),
        ]

    def test_samples_to_reach(self):
        rows = [(10, 2.0, None, 1), (20, 0.6, None, 1), (30, 0.4, None, 1)]
        self.assertEqual(aggregate.samples_to_reach(rows, 0.6), 20)
        self.assertEqual(aggregate.samples_to_reach(rows, 0.3), None)
        self.assertEqual(aggregate.samples_to_reach(rows, None), None)

    def test_against_the_reference_final_mean(self):
        stats = aggregate.final_stats(self.trials)
        history = aggregate.history_stats(self.trials)
        eff = aggregate.sample_efficiency(stats, history, ["p", "q"],
                                          ["rec", "mi", "prbs"])
        # rec's final mean is 0.6: rec itself at 30, mi at 20, prbs never.
        self.assertEqual(eff["p"], {"rec": 30, "mi": 20, "prbs": None})
        # No rec in q: nothing to reach.
        self.assertEqual(eff["q"], {"rec": None, "mi": None, "prbs": None})

    def test_table_section(self):
        stats = aggregate.final_stats(self.trials)
        history = aggregate.history_stats(self.trials)
        md = aggregate.markdown_table(stats, ["p"], ["rec", "mi", "prbs"],
                                      history=history)
        self.assertIn("| **Samples to reach rec's final RMSE** | |", md)
        self.assertIn("| mi | **20** |", md)
        self.assertIn("| rec | 30 |", md)
        self.assertIn("| prbs | not reached |", md)
        self.assertNotIn("Samples to reach", aggregate.markdown_table(
            stats, ["p"], ["rec", "mi"]))


class BestMarkingTest(unittest.TestCase):
    def test_lowest_and_highest(self):
        cells = {"rec": 1.4, "pa": 2.5, "prbs": 5.7, "sep": None}
        self.assertEqual(aggregate.best_in_column(cells, True, 1), {"rec"})
        self.assertEqual(aggregate.best_in_column(cells, False, 1), {"prbs"})

    def test_ties_as_displayed_are_all_marked(self):
        cells = {"rec": 1.791, "pa": 1.789, "greedy": 1.92}
        self.assertEqual(aggregate.best_in_column(cells, True, 2), {"rec", "pa"})
        self.assertEqual(aggregate.best_in_column(cells, True, 3), {"pa"})

    def test_empty_column(self):
        self.assertEqual(aggregate.best_in_column({"rec": None}, True, 2), set())

    def test_markdown_table(self):
        trials = [
            trial("pendulum", "rec", 0, [[10, 1.2]], cov=0.40),
            trial("pendulum", "rec", 1, [[10, 1.6]], cov=0.50),
            trial("pendulum", "pa", 0, [[10, 2.5]], cov=0.55),
            trial("pendulum", "pa", 1, [[10, 2.5]], cov=0.55),
            trial("dipc", "pa", 0, [[10, 1.79]], cov=0.75),
        ]
        stats = aggregate.final_stats(trials)
        md = aggregate.markdown_table(stats, ["pendulum", "dipc"], ["rec", "pa"],
                                      {"pendulum": "Pendulum", "dipc": "DIPC"},
                                      {"pa": "p&a"})
        lines = md.strip().split("\n")
        self.assertEqual(lines[0], "| | Pendulum | DIPC |")
        self.assertEqual(lines[1], "|---|---|---|")
        self.assertEqual(lines[2], "| **Final RMSE** | | |")
        # Columns get three significant digits of their best mean.
        self.assertEqual(lines[3], "| rec | **1.40 ± 0.28** | n/a |")
        self.assertEqual(lines[4], "| p&a | 2.50 ± 0.00 | **1.79 (n=1)** |")
        self.assertEqual(lines[5], "| **Coverage, marginal (% of region)** | | |")
        self.assertEqual(lines[6], "| rec | 45.0 ± 7.1 | n/a |")
        self.assertEqual(lines[7], "| p&a | **55.0 ± 0.0** | **75.0 (n=1)** |")
        self.assertEqual(lines[8], "| **Coverage, joint cells (% of region)** | | |")
        self.assertEqual(lines[9], "| rec | n/a | n/a |")
        self.assertEqual(len(lines), 11)
        for line in lines:
            self.assertEqual(line.count("|"), 4, line)

    def test_trial_count_table(self):
        stats = aggregate.final_stats([trial("pendulum", "rec", 0, [[10, 1.0]])])
        md = aggregate.trial_count_table(
            stats, {("pendulum", "rec"): 3, ("pendulum", "pa"): 2},
            ["pendulum"], ["rec", "pa", "sep"])
        self.assertIn("| rec | 1/3 |", md)
        self.assertIn("| pa | 0/2 |", md)
        self.assertIn("| sep | - |", md)


class CsvTest(unittest.TestCase):
    def test_write_and_read_back(self):
        trials = [
            trial("pendulum", "rec", 1, [[10, 0.9], [20, 0.25]], cov=0.825, joint=0.37,
                  plan=218.25),
            trial("dipc", "pa", 0, [[10, float("nan")], [20, 3.1]], cov=0.1, joint=None,
                  plan=12.5),
        ]
        with tempfile.TemporaryDirectory() as d:
            path = os.path.join(d, "results.csv")
            aggregate.write_csv(path, trials)
            with open(path, newline="") as f:
                rows = list(csv.reader(f))
            self.assertEqual(rows[0], aggregate.CSV_COLUMNS)
            self.assertEqual(rows[0], ["system", "strategy", "trial", "samples", "rmse",
                                       "coverage_marginal", "coverage_joint",
                                       "plan_ms"])
            # Sorted by system, strategy, trial; one row per history point.
            self.assertEqual(len(rows), 5)
            self.assertEqual(rows[1], ["dipc", "pa", "0", "10", "", "", "", ""])
            self.assertEqual(rows[2], ["dipc", "pa", "0", "20", "3.1", "0.1", "", "12.5"])
            self.assertEqual(rows[3], ["pendulum", "rec", "1", "10", "0.9", "", "", ""])
            self.assertEqual(rows[4], ["pendulum", "rec", "1", "20", "0.25", "0.825",
                                       "0.37", "218.25"])
            back = {(t["system"], t["trial"]): t for t in aggregate.read_csv(path)}
            rec = back[("pendulum", 1)]
            self.assertEqual(rec["rmse_history"], [[10, 0.9], [20, 0.25]])
            self.assertEqual(rec["final_rmse"], 0.25)
            self.assertEqual(rec["coverage_joint"], 0.37)
            self.assertEqual(rec["plan_ms_p50"], 218.25)
            self.assertNotIn("coverage_joint", back[("dipc", 0)])
            self.assertEqual(check.check_csv(path, [("pendulum", "rec")]), [])
            self.assertEqual(check.check_csv(path, [("pendulum", "pa")]),
                             [f"{path}: no rows for pendulum/pa"])

    def test_trial_without_history_gets_one_row(self):
        rows = aggregate.csv_rows([trial("p", "rec", 0, [], cov=0.2)])
        self.assertEqual(rows, [["p", "rec", "0", "0", "", "0.2", "", "10.0"]])

    def test_wrong_columns_are_reported(self):
        with tempfile.TemporaryDirectory() as d:
            path = os.path.join(d, "results.csv")
            with open(path, "w") as f:
                f.write("system,strategy,rmse\npendulum,rec,1\n")
            problems = check.check_csv(path, [])
            self.assertEqual(len(problems), 1)
            self.assertIn("columns", problems[0])


class SnapshotConfigsTest(unittest.TestCase):
    """run.py runs every trial on a copy of its config taken at the start."""

    def test_trials_point_at_copies_that_later_edits_do_not_reach(self):
        import run

        class T:
            def __init__(self, config):
                self.config = config

        with tempfile.TemporaryDirectory() as d:
            original = os.path.join(d, "pendulum.textproto")
            with open(original, "w") as f:
                f.write("system: 'pendulum'\n")
            trials = [T(original), T(original)]
            out = os.path.join(d, "out")
            run.snapshot_configs(trials, out)
            copy = os.path.join(out, "configs", "pendulum.textproto")
            self.assertEqual([t.config for t in trials], [copy, copy])
            with open(original, "w") as f:
                f.write("edited\n")
            with open(copy) as f:
                self.assertEqual(f.read(), "system: 'pendulum'\n")


class EstimatorTest(unittest.TestCase):
    """run.py's time-left estimate (which finished or running trial it trusts)."""

    def test_order_of_preference(self):
        import run  # bench/paper/run.py; main() is not called on import

        class T:
            def __init__(self, system, strategy, wall=None):
                self.system, self.strategy, self.wall = system, strategy, wall
                self.pair = (system, strategy)

        est = run.Estimator()
        self.assertIsNone(est.estimate(T("p", "rec"), 300))
        est.partial = [("p", "rec", 100, 50.0)]  # running: 0.5 s per sample so far
        self.assertAlmostEqual(est.estimate(T("p", "rec"), 300), 150.0)
        self.assertAlmostEqual(est.estimate(T("d", "pa"), 200), 100.0)
        est.add(T("d", "rec", wall=40.0), 20)  # finished: 2 s per sample
        self.assertAlmostEqual(est.estimate(T("p", "rec"), 300), 150.0)
        self.assertAlmostEqual(est.estimate(T("u", "rec"), 10), 20.0)
        self.assertAlmostEqual(est.estimate(T("d", "pa"), 10), 20.0)
        est.add(T("p", "rec", wall=90.0), 300)
        est.add(T("p", "rec", wall=110.0), 300)
        self.assertAlmostEqual(est.estimate(T("p", "rec"), 300), 100.0)


class PngCheckTest(unittest.TestCase):
    def test_signature_and_size(self):
        with tempfile.TemporaryDirectory() as d:
            good = os.path.join(d, "good.png")
            with open(good, "wb") as f:
                f.write(check.PNG_SIGNATURE + b"\x00\x00\x00\x0dIHDR"
                        + (640).to_bytes(4, "big") + (480).to_bytes(4, "big") + b"\x08")
            self.assertEqual(check.check_png(good), "")
            bad = os.path.join(d, "bad.png")
            with open(bad, "wb") as f:
                f.write(b"GIF89a" + b"\x00" * 30)
            self.assertIn("signature", check.check_png(bad))
            empty = os.path.join(d, "empty.png")
            open(empty, "wb").close()
            self.assertIn("too short", check.check_png(empty))
            self.assertIn("missing", check.check_png(os.path.join(d, "none.png")))


try:
    import plots  # bench/paper/plots.py (needs python3-matplotlib)
except ImportError:
    plots = None


def rows(*points, n=3, std=0.01):
    """history_stats rows (samples, mean, std, n) for means at 10, 20, ..."""
    return [(10 * (i + 1), m, std, n) for i, m in enumerate(points)]


@unittest.skipIf(plots is None, "matplotlib not installed")
class PlotRulesTest(unittest.TestCase):
    """bench/paper/plots.py: which strategies are highlighted, when the y axis is
    logarithmic, what the legends say, the resolution of the PNGs."""

    STRATEGIES = ["prbs", "chirp", "rec", "pa", "mi", "roi", "uniform"]

    def history(self):
        return {
            ("p", "prbs"): rows(1.0, 0.50),
            ("p", "chirp"): rows(1.0, 0.90),
            ("p", "rec"): rows(1.0, 0.30),
            ("p", "pa"): rows(1.0, 0.40),
            ("p", "mi"): rows(1.0, 0.35, n=2),
            ("p", "roi"): [(10, 1.0, None, 1), (20, 0.60, None, 1)],
            # The reference is lowest but never ranked nor highlighted.
            ("p", "uniform"): rows(0.5, 0.20, n=5),
            ("other", "rec"): rows(9.0, 0.01),
        }

    def test_highlighted_are_the_three_lowest_final_means(self):
        plan = plots.panel_plan(self.history(), "p", self.STRATEGIES)
        self.assertEqual(plan["ranked"], ["rec", "mi", "pa", "prbs", "roi", "chirp"])
        self.assertEqual(plan["highlighted"], ["rec", "mi", "pa"])
        self.assertEqual(plan["references"], ["uniform"])
        self.assertEqual(plan["order"][-1], "uniform")

    def test_a_tie_as_displayed_is_highlighted_too(self):
        h = self.history()
        h[("p", "prbs")] = rows(1.0, 0.40004)  # reads 0.4 like pa (0.40)
        plan = plots.panel_plan(h, "p", self.STRATEGIES)
        self.assertEqual(plan["highlighted"], ["rec", "mi", "pa", "prbs"])
        # An exact tie in the ranking: the order of the strategy list decides.
        h[("p", "prbs")] = rows(1.0, 0.30)
        plan = plots.panel_plan(h, "p", self.STRATEGIES)
        self.assertEqual(plan["ranked"][:2], ["prbs", "rec"])

    def test_few_strategies_are_all_highlighted(self):
        plan = plots.panel_plan(self.history(), "other", self.STRATEGIES)
        self.assertEqual(plan["highlighted"], ["rec"])
        self.assertIsNone(plots.panel_plan(self.history(), "none", self.STRATEGIES))

    def test_log_scale_only_beyond_three_quarters_of_a_decade(self):
        # p: means from 1.0 down to 0.2: a factor 5 < 10^0.75 = 5.62: linear from 0.
        plan = plots.panel_plan(self.history(), "p", self.STRATEGIES)
        self.assertFalse(plan["log"])
        self.assertEqual(plan["ylim"][0], 0.0)
        self.assertAlmostEqual(plan["ylim"][1], 1.01 * 1.05)  # rec's band: 1.0 + 0.01
        # A factor 6 (first point included): log, limits around the mean curves.
        h = self.history()
        h[("p", "uniform")] = rows(0.5, 1.0 / 6.0)
        plan = plots.panel_plan(h, "p", self.STRATEGIES)
        self.assertTrue(plan["log"])
        self.assertAlmostEqual(plan["ylim"][0], 1.0 / 6.0 / 1.15)
        self.assertAlmostEqual(plan["ylim"][1], 1.01 * 1.15)
        # other: 9.0 to 0.01, three decades.
        self.assertTrue(plots.panel_plan(h, "other", self.STRATEGIES)["log"])

    def test_the_highlighted_bands_fit_within_the_axes(self):
        h = self.history()
        h[("p", "rec")] = rows(1.0, 0.30, std=0.5)  # a wide band: 1.5 at the top
        plan = plots.panel_plan(h, "p", self.STRATEGIES)
        self.assertAlmostEqual(plan["ylim"][1], 1.5 * 1.05)
        h[("p", "roi")] = rows(1.0, 0.6, std=3.0)  # not highlighted: no band, no room
        self.assertAlmostEqual(plots.panel_plan(h, "p", self.STRATEGIES)["ylim"][1], 1.575)
        # Log: the lower band ends that are positive set the bottom, others are left out.
        h = self.history()
        h[("p", "uniform")] = rows(0.5, 1.0 / 6.0)
        h[("p", "rec")] = rows(1.0, 0.30, std=0.29)  # 0.01 at the bottom
        h[("p", "pa")] = rows(1.0, 0.40, std=0.5)  # <= 0: left out
        plan = plots.panel_plan(h, "p", self.STRATEGIES)
        self.assertTrue(plan["log"])
        self.assertAlmostEqual(plan["ylim"][0], 0.01 / 1.15)
        self.assertAlmostEqual(plan["ylim"][1], 1.5 * 1.15)

    def test_drawn_panel(self):
        import matplotlib.pyplot as plt
        from matplotlib.collections import PolyCollection
        fig, ax = plt.subplots()
        try:
            plan = plots.draw_rmse_panel(ax, self.history(), "p", self.STRATEGIES,
                                         {"uniform": "uniform (ideal)"}, "P")
            self.assertEqual(ax.get_yscale(), "linear")
            texts = [t.get_text() for t in ax.get_legend().get_texts()]
            self.assertEqual(texts, [
                "rec (n=3): 0.3", "mi (n=2): 0.35", "pa (n=3): 0.4",
                "prbs (n=3): 0.5", "roi (n=1): 0.6", "chirp (n=3): 0.9",
                "uniform (ideal) (n=5): 0.2"])
            widths = {line.get_label().split(" ")[0]: line.get_linewidth()
                      for line in ax.get_lines()}
            for s in plan["highlighted"]:
                for other in ("prbs", "roi", "chirp", "uniform"):
                    self.assertGreater(widths[s], widths[other])
            # One ± std band per highlighted strategy, none for the others.
            bands = [c for c in ax.collections if isinstance(c, PolyCollection)]
            self.assertEqual(len(bands), 3)
            # The legend is outside the axes (anchored right of them).
            self.assertGreater(ax.get_legend().get_bbox_to_anchor().x0,
                               ax.get_window_extent().x1)
            ax.clear()
            h = self.history()
            h[("p", "uniform")] = rows(0.5, 0.05)
            plots.draw_rmse_panel(ax, h, "p", self.STRATEGIES, {}, "P")
            self.assertEqual(ax.get_yscale(), "log")
        finally:
            plt.close(fig)

    def test_trial_count_text(self):
        self.assertEqual(plots.trial_count_text(3, 3), "n=3")
        self.assertEqual(plots.trial_count_text(1, 3), "n=1-3")
        self.assertEqual(plots.legend_label("rec", 2, 3, 0.215349), "rec (n=2-3): 0.215")

    def test_pngs_at_150_dpi(self):
        trials = [trial("p", "rec", k, [[10, 1.0 + k], [20, 0.5 + k]]) for k in range(3)]
        trials += [trial("q", "mi", 0, [[10, 2.0], [20, 1.0]], cov=0.7)]
        history = aggregate.history_stats(trials)
        stats = aggregate.final_stats(trials)
        with tempfile.TemporaryDirectory() as d:
            paths = [os.path.join(d, n) for n in ("a.png", "b.png", "c.png")]
            self.assertTrue(plots.plot_rmse_system(paths[0], history, "p", ["rec", "mi"],
                                                   "P", {}))
            self.assertTrue(plots.plot_rmse_all(paths[1], history, ["p", "q"],
                                                ["rec", "mi"], {}, {}))
            self.assertTrue(plots.plot_coverage(paths[2], stats, ["p", "q"],
                                                ["rec", "mi"], {}, {}))
            for path in paths:
                self.assertEqual(check.check_png(path), "")
                self.assertGreaterEqual(plots.png_dpi(path), 150, path)
            self.assertFalse(plots.plot_rmse_system(os.path.join(d, "x.png"), history,
                                                    "none", ["rec"], "N", {}))
            self.assertFalse(os.path.exists(os.path.join(d, "x.png")))


class CombineRunsTest(unittest.TestCase):
    """run.py --report_only with several results directories and a results.csv."""

    def write_run(self, d, meta, records):
        import json
        os.makedirs(d)
        with open(os.path.join(d, "run.json"), "w") as f:
            json.dump({"meta": meta, "trials": records}, f)

    @staticmethod
    def record(system, strategy, k, final, status="ok"):
        t = trial(system, strategy, k, [[10, 2.0], [20, final]])
        return {"system": system, "strategy": strategy, "trial": k, "seed": k,
                "status": status, "error": "" if status == "ok" else "boom",
                "wall": 1.0, "result": t if status == "ok" else None}

    @staticmethod
    def meta(systems, strategies, started, commit):
        return {"mode": "full", "started": started, "command": "run.py", "jobs": 2,
                "servers": 2, "machine": "m", "commit": commit, "systems": systems,
                "strategies": strategies, "planned": {}, "samples": {"pendulum": 20},
                "skipped": [], "wall_s": 10.0}

    def test_later_source_wins_and_failures_do_not_replace(self):
        import contextlib
        import io
        import run
        with tempfile.TemporaryDirectory() as d:
            a, b = os.path.join(d, "a"), os.path.join(d, "b")
            self.write_run(a, self.meta(["pendulum"], ["rec", "roi"], "T1", "c1"), [
                self.record("pendulum", "rec", 0, 0.5),
                self.record("pendulum", "rec", 1, 0.6),
                self.record("pendulum", "roi", 0, 0.3)])
            self.write_run(b, self.meta(["pendulum"], ["rec"], "T2", "c2"), [
                self.record("pendulum", "rec", 0, 0.4),  # replaces a's trial 0
                self.record("pendulum", "rec", 1, None, status="failed")])
            cfg = run.load_config(run.DEFAULT_CONFIG)
            meta, records = run.merge_sources([a, b], cfg, "cmd")
            finals = {(r["system"], r["strategy"], r["trial"]): r["result"]["final_rmse"]
                      for r in records}
            self.assertEqual(finals, {("pendulum", "rec", 0): 0.4,
                                      ("pendulum", "rec", 1): 0.6,
                                      ("pendulum", "roi", 0): 0.3})
            self.assertEqual(meta["strategies"], ["rec", "roi"])  # benchmark.json order
            self.assertEqual(meta["planned"], {"pendulum/rec": 2, "pendulum/roi": 1})
            self.assertEqual(meta["started"], "T1 to T2")
            self.assertEqual(meta["commit"], "c1, c2")

            out = os.path.join(d, "out")
            with contextlib.redirect_stdout(io.StringIO()):
                run.report_only([a, b], cfg, out, None, ["rec"])
            back = aggregate.read_csv(os.path.join(out, "results.csv"))
            self.assertEqual(sorted((t["strategy"], t["final_rmse"]) for t in back),
                             [("rec", 0.4), ("rec", 0.6)])
            # The combined results.csv alone re-plots the same figure.
            again = os.path.join(d, "again")
            with contextlib.redirect_stdout(io.StringIO()):
                run.report_only([os.path.join(out, "results.csv")], cfg, again)
            for name in ("rmse_pendulum.png", "rmse_all.png", "coverage.png"):
                self.assertEqual(check.check_png(os.path.join(again, name)), "")
                if plots is not None:
                    with open(os.path.join(out, name), "rb") as f1, \
                            open(os.path.join(again, name), "rb") as f2:
                        self.assertEqual(f1.read(), f2.read(), name)


if __name__ == "__main__":
    unittest.main(verbosity=2)
