#!/usr/bin/env python3
"""Draw the figures of docs/figures.md from the CSV files of `holosym figures`.

Usage: python3 tools/plot_figures.py DATA_DIR PNG_DIR
(`make figures` runs `holosym figures --out build/figures` and then this script in the
virtual environment build/venv, which tools/python_venv.sh makes.) Every number drawn comes
from DATA_DIR; nothing is typed in here but the slopes 2M of the convergence figure.
"""
import csv
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import matplotlib.ticker  # noqa: E402,F401

FLOOR = 1e-37  # stands in for exact zeros on log axes


def read(path):
    with open(path, newline="") as handle:
        return list(csv.DictReader(handle))


def column(rows, name):
    return [float(row[name]) for row in rows]


def positive(values):
    return [max(abs(v), FLOOR) for v in values]


def fig1(data, out):
    rows = read(os.path.join(data, "fig1_pendulum.csv"))
    t = column(rows, "t")
    fig, axes = plt.subplots(4, 1, figsize=(8, 9), sharex=True)
    for i, name in enumerate(("x", "y", "z"), start=1):
        axes[0].plot(t, column(rows, f"q{i}"), lw=0.8, label=name)
        axes[1].plot(t, column(rows, f"p{i}"), lw=0.8, label=f"p_{name}")
    axes[2].plot(t, column(rows, "lambda1"), lw=0.8, color="C3")
    axes[3].semilogy(t[1:], positive(column(rows, "constraint_residual")[1:]), ".", ms=1.5,
                     color="C4")
    axes[0].set_ylabel("q [m]")
    axes[1].set_ylabel("p [kg m/s]")
    axes[2].set_ylabel("lambda")
    axes[3].set_ylabel("max |phi| at the\ndisplacement nodes")
    axes[3].set_xlabel("t [s]")
    axes[0].legend(loc="upper right", ncol=3, fontsize=8)
    axes[1].legend(loc="upper right", ncol=3, fontsize=8)
    axes[0].set_title("Spherical pendulum, (M, N, G) = (2, 1, 3), h = 1/8 (paper Fig. 1)")
    fig.tight_layout()
    fig.savefig(os.path.join(out, "fig1_pendulum.png"), dpi=120)
    plt.close(fig)


def fig2(data, out):
    fig, axes = plt.subplots(2, 1, figsize=(8, 5.5), sharex=True)
    for ax, (order, label) in zip(axes, ((2, "(a) N = M - 1 = G - 2 = 1"),
                                         (7, "(b) N = M - 1 = G - 2 = 6"))):
        rows = read(os.path.join(data, f"fig2_energy_M{order}.csv"))
        ax.plot(column(rows, "t"), column(rows, "energy_error"), lw=0.8)
        ax.set_ylabel("(H - H0)/H0")
        ax.set_title(label + ", h = 1/2", fontsize=10)
    axes[1].set_xlabel("t [s]")
    fig.suptitle("Spherical pendulum: relative energy error (paper Fig. 2)")
    fig.tight_layout()
    fig.savefig(os.path.join(out, "fig2_energy.png"), dpi=120)
    plt.close(fig)


def fig4(data, out):
    coarse = read(os.path.join(data, "fig4_linkage_coarse.csv"))
    fine = read(os.path.join(data, "fig4_linkage_fine.csv"))
    fig, ax = plt.subplots(figsize=(8, 4.5))
    for ball, (x, y) in enumerate((("q1", "q2"), ("q3", "q4")), start=1):
        ax.plot(column(fine, x), column(fine, y), lw=0.8, color=f"C{ball - 1}",
                label=f"ball {ball}: N = 4, h = 1/8")
        ax.plot(column(coarse, x), column(coarse, y), "*", ms=5, color=f"C{ball - 1}",
                mfc="none", label=f"ball {ball}: N = 1, h = 1/2")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend(fontsize=8, ncol=2, loc="upper center")
    ax.set_title("Spring-linkage: the balls' trajectories (paper Fig. 4)")
    fig.tight_layout()
    fig.savefig(os.path.join(out, "fig4_linkage.png"), dpi=120)
    plt.close(fig)


def fig5(data, out):
    rows = read(os.path.join(data, "fig5_constraints.csv"))
    fig, ax = plt.subplots(figsize=(8, 3.8))
    t = column(rows, "t")
    total = column(rows, "phi_sum")
    ax.plot(t, total, ".", ms=3)
    ax.axhline(0, color="0.6", lw=0.5)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("phi1 + phi2 + phi3")
    ax.set_title("Spring-linkage, N = 1, h = 1/2: constraints at the displacement nodes "
                 "(paper Fig. 5)", fontsize=10)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "fig5_constraints.png"), dpi=120)
    plt.close(fig)


def long_run(data, out):
    rows = read(os.path.join(data, "long_run.csv"))
    methods = [("holosym", "holosym (M, N, G) = (2, 1, 3)"),
               ("rattle", "RATTLE composed (triple jump)"),
               ("rk4-index1", "Runge-Kutta 4, index-1 form")]
    fig, ax = plt.subplots(figsize=(8, 5.5))
    steps = 0
    for index, (key, label) in enumerate(methods):
        mine = [row for row in rows if row["method"] == key]
        if not mine:
            continue
        steps = max(steps, int(mine[-1]["step"]))
        t = column(mine, "t")
        ax.loglog(t, positive(column(mine, "energy_error")), lw=1.0, color=f"C{index}",
                  label=label + ": |H - H0|/|H0|")
        ax.loglog(t, positive(column(mine, "constraint_residual")), lw=0.8, ls="--",
                  color=f"C{index}", label=label + ": |phi|")
    ax.set_xlabel("t [s]  (h = 1/8)")
    ax.set_ylabel("maximum over windows of steps")
    ax.legend(fontsize=7, loc="center right")
    ax.grid(True, which="major", lw=0.3)
    ax.set_title(f"Spherical pendulum, order 4, {steps} steps: bounded against drifting "
                 "errors", fontsize=10)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "long_run.png"), dpi=120)
    plt.close(fig)


def convergence(data, out):
    rows = [row for row in read(os.path.join(data, "convergence.csv")) if int(row["status"]) == 0]
    fig, axes = plt.subplots(1, 2, figsize=(11, 5))
    orders = sorted({int(row["M"]) for row in rows})
    for order in orders:
        mine = [row for row in rows if int(row["M"]) == order]
        h = column(mine, "h")
        color = plt.cm.viridis((order - 1) / max(1, max(orders) - 1))
        for ax, name in zip(axes, ("energy_error", "global_error")):
            error = positive(column(mine, name))
            ax.loglog(h, error, "o-", ms=3, lw=1, color=color, label=f"M = {order}")
            # The slope 2M, a decade below the first point above the round-off floor.
            good = [(x, e) for x, e in zip(h, error) if e > 1e-28]
            if len(good) > 1:
                x0, e0 = good[0]
                xs = [x0, good[-1][0]]
                ax.loglog(xs, [e0 / 10 * (x / x0) ** (2 * order) for x in xs], "--", lw=0.8,
                          color=color)
    steps = sorted({float(row["h"]) for row in rows})
    for ax, title in zip(axes, ("energy error E = max |(H - H0)/H0|",
                                "global error max |q(10) - q_ref(10)|")):
        ax.set_xlabel("h")
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.set_xticks(steps)
        ax.set_xticklabels([f"1/{round(1 / x)}" for x in steps])
        ax.set_title(title, fontsize=10)
        ax.set_ylim(1e-34, 1)
        ax.grid(True, which="major", lw=0.3)
    axes[0].set_ylabel("error at T = 10")
    axes[1].legend(fontsize=7, ncol=2)
    fig.suptitle("Spherical pendulum, N = M - 1, G = M + 1: measured errors (solid) and "
                 "slopes 2M (dashed, a decade lower)", fontsize=11)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "convergence.png"), dpi=120)
    plt.close(fig)


def orbits(rows):
    """The rows of a `holosym poincare` file grouped by orbit, in id order."""
    grouped = {}
    for row in rows:
        grouped.setdefault(int(row["orbit"]), []).append(row)
    return [grouped[k] for k in sorted(grouped)]


def poincare(data, out):
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.8))
    for name, color, label in (("poincare_double_regular.csv", "C0", "near theta = (0.5, 0.3)"),
                               ("poincare_double_chaotic.csv", "C3", "near theta = (2, 2.5)")):
        for k, orbit in enumerate(orbits(read(os.path.join(data, name)))):
            axes[0].plot(column(orbit, "q3"), column(orbit, "p3"), ".", ms=2, color=color,
                         label=label if k == 0 else None)
    axes[0].set_xlabel("x2 (= l2 sin theta2)")
    axes[0].set_ylabel("px2")
    axes[0].set_title("Double pendulum: crossings of x1 = 0 rising")
    axes[0].legend(loc="upper right", fontsize=8, markerscale=4)
    for orbit in orbits(read(os.path.join(data, "poincare_spherical.csv"))):
        axes[1].plot(column(orbit, "q1"), column(orbit, "p1"), ".", ms=2)
    axes[1].set_xlabel("x")
    axes[1].set_ylabel("px")
    axes[1].set_title("Spherical pendulum: crossings of y = 0 rising")
    fig.suptitle("holosym poincare, (M, N, G) = (4, 3, 5), h = 1/16: each colour or "
                 "series one orbit", fontsize=9)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "poincare.png"), dpi=120)
    plt.close(fig)


def main():
    if len(sys.argv) != 3:
        print(__doc__, file=sys.stderr)
        sys.exit(2)
    data, out = sys.argv[1], sys.argv[2]
    os.makedirs(out, exist_ok=True)
    drawn = []
    for name, draw in (("fig1_pendulum.csv", fig1), ("fig2_energy_M2.csv", fig2),
                       ("fig4_linkage_coarse.csv", fig4), ("fig5_constraints.csv", fig5),
                       ("long_run.csv", long_run), ("convergence.csv", convergence),
                       ("poincare_spherical.csv", poincare)):
        if os.path.exists(os.path.join(data, name)):
            draw(data, out)
            drawn.append(draw.__name__)
    if not drawn:
        print(f"plot_figures: no data in {data}", file=sys.stderr)
        sys.exit(1)
    print("plot_figures: drew " + ", ".join(drawn) + " into " + out, file=sys.stderr)


if __name__ == "__main__":
    main()
