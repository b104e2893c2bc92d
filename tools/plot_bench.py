#!/usr/bin/env python3
"""Plots of `holosym bench`, from the CSV files of one benchmark directory.

- DIR/work_precision.png: error at T against CPU seconds, one panel per system; for each
  of holosym, RATTLE composed inside holosym (all of GNI_COMP's compositions together)
  and heyoka (index-1 form), the cheapest runs joined into a front, real128 solid and
  real64 dotted (bench.csv, bench64.csv, heyoka.csv, heyoka64.csv); and holosym run
  through --accuracy, one star (real128) or cross (real64) per target at the CPU seconds
  of its pilot and run together.
- DIR/scaling.png: cost per step and peak memory of the chain of K pendula against K,
  reduced step and general path, real128 and real64 (scaling.csv, scaling64.csv).

Usage: python3 tools/plot_bench.py DIR (make bench runs it in its virtual environment).
"""
import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

SYSTEMS = [("pendulum", "spherical pendulum, T = 10"), ("linkage", "spring-linkage, T = 10"),
           ("planar", "planar pendulum, T = 100")]
FAMILIES = [("holosym", "holosym", "C0", "o"), ("rattle", "RATTLE compositions (in holosym)",
                                                 "C1", "s"),
            ("heyoka", "heyoka (index-1)", "C2", "^")]


def read_csv(path):
    if not os.path.exists(path):
        return []
    with open(path, newline="") as handle:
        return list(csv.DictReader(handle))


def front(points):
    """Pareto front: runs that no cheaper run beats in error."""
    result, best = [], float("inf")
    for seconds, error in sorted(points):
        if error < best:
            result.append((seconds, error))
            best = error
    return result


def family(method):
    if method == "holosym":
        return "holosym"
    if method.startswith("rattle-"):
        return "rattle"
    if method == "heyoka":
        return "heyoka"
    return None


def work_precision(directory):
    rows = []
    for name in ("bench.csv", "bench64.csv", "heyoka.csv", "heyoka64.csv"):
        for row in read_csv(os.path.join(directory, name)):
            if int(row["status"]) != 0 or float(row["seconds"]) <= 0:
                continue
            rows.append(row)
    if not rows:
        return None
    figure, axes = plt.subplots(1, 3, figsize=(16, 5.5))
    for axis, (system, title) in zip(axes, SYSTEMS):
        for precision, line in (("real128", "-"), ("real64", ":")):
            for key, label, colour, marker in FAMILIES:
                points = [(float(r["seconds"]), max(float(r["error"]), 1e-36)) for r in rows
                          if r["system"] == system and family(r["method"]) == key
                          and r["precision"] == precision]
                if not points:
                    continue
                curve = front(points)
                axis.loglog([p[0] for p in curve], [p[1] for p in curve], line, color=colour,
                            marker=marker, markersize=4, label="%s, %s" % (label, precision))
            # holosym as `simulate --accuracy TARGET` runs it: one point per target, at
            # the CPU seconds of its pilot and run together.
            chosen = [(float(r["seconds"]) + float(r["compile_seconds"]),
                       max(float(r["error"]), 1e-36)) for r in rows
                      if r["system"] == system and r["method"] == "holosym-accuracy"
                      and r["precision"] == precision]
            if chosen:
                axis.loglog([p[0] for p in chosen], [p[1] for p in chosen], color="C0", marker="*" if precision == "real128" else "x",
                            markersize=8, linestyle="none",
                            label="holosym --accuracy (pilot + run), %s" % precision)
        axis.set_title(title)
        axis.set_xlabel("CPU seconds (one core; heyoka without compile time)")
        axis.set_ylabel("global error at T")
        axis.grid(True, which="major", alpha=0.3)
        axis.legend(fontsize=7)
    figure.suptitle("Work-precision, cheapest runs per method, measured in one run "
                    "(lower left is better)")
    figure.tight_layout()
    output = os.path.join(directory, "work_precision.png")
    figure.savefig(output, dpi=110)
    return output


def scaling(directory):
    rows = read_csv(os.path.join(directory, "scaling.csv")) + \
        read_csv(os.path.join(directory, "scaling64.csv"))
    rows = [r for r in rows if int(r["status"]) == 0 and float(r["seconds_per_step"]) > 0]
    if not rows:
        return None
    figure, (cost, memory) = plt.subplots(1, 2, figsize=(13, 5))
    styles = {("reduced", "real128"): ("C0", "-o"), ("reduced", "real64"): ("C0", ":o"),
              ("general", "real128"): ("C3", "-s"), ("general", "real64"): ("C3", ":s")}
    for (path, precision), (colour, style) in styles.items():
        points = sorted((int(r["links"]), float(r["seconds_per_step"]),
                         float(r["max_rss_kb"]) / 1024) for r in rows
                        if r["path"] == path and r["precision"] == precision)
        if not points:
            continue
        label = "%s path, %s" % (path, precision)
        cost.loglog([p[0] for p in points], [p[1] for p in points], style, color=colour,
                    markersize=4, label=label)
        memory.loglog([p[0] for p in points], [p[2] for p in points], style, color=colour,
                      markersize=4, label=label)
    reduced = sorted((int(r["links"]), float(r["seconds_per_step"])) for r in rows
                     if r["path"] == "reduced" and r["precision"] == "real128")
    if reduced:
        k0, t0 = reduced[-1]
        ks = [k for k, _ in reduced]
        cost.loglog(ks, [t0 * k / k0 for k in ks], "k--", linewidth=0.8, label="slope 1")
    cost.set_xlabel("links K (n = 2K, m = K)")
    cost.set_ylabel("CPU seconds per step, (M, N, G) = (4, 3, 5), h = 0.01")
    memory.set_xlabel("links K")
    memory.set_ylabel("peak resident memory of the process [MB]")
    for axis in (cost, memory):
        axis.grid(True, which="major", alpha=0.3)
        axis.legend(fontsize=8)
    figure.suptitle("Chain of K planar pendula: cost per step and memory against K")
    figure.tight_layout()
    output = os.path.join(directory, "scaling.png")
    figure.savefig(output, dpi=110)
    return output


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: plot_bench.py DIR")
    directory = sys.argv[1]
    written = [p for p in (work_precision(directory), scaling(directory)) if p]
    if not written:
        sys.exit("plot_bench.py: no bench or scaling rows in %s" % directory)
    for path in written:
        print("plot_bench.py: wrote " + path)


if __name__ == "__main__":
    main()
