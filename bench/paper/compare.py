"""Paired comparison of two runs of bench/paper/run.py (a variant against a
reference, e.g. two --session_override values on the same seeds): per system and
metric, the geometric mean of variant / reference with its 90 % paired-bootstrap
interval and the seeds where the variant is lower.

  python3 bench/paper/compare.py VARIANT/trials.csv REFERENCE/trials.csv \
      [--metrics final_rmse midway_rmse rollout_rmse_30 midway_rollout_rmse_30]
"""

import argparse
import csv

import aggregate


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("variant", help="the variant's trials.csv")
    parser.add_argument("reference", help="the reference's trials.csv")
    parser.add_argument("--metrics", nargs="+",
                        default=["final_rmse", "midway_rmse", "rollout_rmse_30",
                                 "midway_rollout_rmse_30"])
    args = parser.parse_args()
    rows = []
    for path in (args.variant, args.reference):
        with open(path, newline="", encoding="utf-8") as f:
            rows.append(list(csv.DictReader(f)))
    print(aggregate.variant_section(rows[0], rows[1], args.metrics), end="")


if __name__ == "__main__":
    main()
