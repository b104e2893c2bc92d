#!/usr/bin/env python3
"""Work-precision plot of `holosym bench`: error at T against CPU seconds, one panel per
system, the cheapest run of each method per error level joined into a front.

Usage: python3 tools/plot_bench.py DIR   (reads DIR/bench.csv and DIR/bench64.csv,
writes DIR/work_precision.png). Needs matplotlib (make bench installs it with pip).
"""
import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

# The competitor's table (GNI_COMP, cheapest configuration per target): fixed numbers given
# with the benchmark's specification, not measured here (see docs/performance.md).
TABLE_TARGETS = [1e-10, 1e-14, 1e-18, 1e-22, 1e-26]
TABLE = {
    ("pendulum", "real128"): [1.6e-3, 4.9e-3, 0.010, 0.040, 0.083],
    ("linkage", "real128"): [0.024, 0.075, 0.16, 0.31, 1.5],
    ("planar", "real128"): [0.013, 0.050, 0.10, 0.20, 0.79],
    ("pendulum", "real64"): [3.7e-5, 1.3e-4, None, None, None],
    ("linkage", "real64"): [5.9e-4, 1.8e-3, None, None, None],
    ("planar", "real64"): [4.0e-4, 1.8e-3, None, None, None],
}
SYSTEMS = [("pendulum", "spherical pendulum, T = 10"), ("linkage", "spring-linkage, T = 10"),
           ("planar", "planar pendulum, T = 100")]


def read_rows(directory):
    rows = []
    for name in ("bench.csv", "bench64.csv"):
        path = os.path.join(directory, name)
        if not os.path.exists(path):
            continue
        with open(path, newline="") as handle:
            for row in csv.DictReader(handle):
                if int(row["status"]) != 0:
                    continue
                row["error"] = float(row["error"])
                row["seconds"] = float(row["seconds"])
                rows.append(row)
    return rows


def front(points):
    """Pareto front: runs that no cheaper run beats in error."""
    points = sorted(points)
    result, best = [], float("inf")
    for seconds, error in points:
        if error < best:
            result.append((seconds, error))
            best = error
    return result


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: plot_bench.py DIR")
    directory = sys.argv[1]
    rows = read_rows(directory)
    if not rows:
        sys.exit("plot_bench.py: no rows in %s/bench.csv" % directory)
    figure, axes = plt.subplots(1, 3, figsize=(16, 5.5))
    styles = {"holosym": ("C0", "o"), "rattle-triple-jump": ("C1", "s"),
              "rattle-suzuki": ("C2", "^")}
    for axis, (system, title) in zip(axes, SYSTEMS):
        for precision, line in (("real128", "-"), ("real64", ":")):
            for method, (colour, marker) in styles.items():
                points = [(r["seconds"], max(r["error"], 1e-36)) for r in rows
                          if r["system"] == system and r["method"] == method
                          and r["precision"] == precision and r["seconds"] > 0]
                if not points:
                    continue
                curve = front(points)
                label = "%s (%s)" % (method, precision)
                axis.loglog([p[0] for p in curve], [p[1] for p in curve], line,
                            color=colour, marker=marker, markersize=4, label=label)
            table = TABLE.get((system, precision))
            if table:
                xs = [t for t in table if t is not None]
                ys = [e for e, t in zip(TABLE_TARGETS, table) if t is not None]
                axis.loglog(xs, ys, line, color="k", marker="x",
                            label="GNI_COMP table (%s)" % precision)
        axis.set_title(title)
        axis.set_xlabel("CPU seconds (one core)")
        axis.set_ylabel("global error at T")
        axis.grid(True, which="major", alpha=0.3)
        axis.legend(fontsize=7)
    figure.suptitle("holosym work-precision: cheapest runs per method (lower left is better)")
    figure.tight_layout()
    output = os.path.join(directory, "work_precision.png")
    figure.savefig(output, dpi=110)
    print("plot_bench.py: wrote " + output)


if __name__ == "__main__":
    main()
