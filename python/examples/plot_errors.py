"""Energy and constraint errors of the four-bar linkage (example/models/fourbar.hsm)
with (M, N, G) = (8, 7, 9) and h = 1/160 over 20 s, plotted with matplotlib.

    python python/examples/plot_errors.py [--output errors.png]

Runs headless (the Agg backend) and saves a PNG; without matplotlib it prints the
numbers and says how to install it."""

import argparse
import sys

import numpy as np

import holosym


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output", default="fourbar_errors.png", help="PNG to write")
    parser.add_argument("--T", default="20", help="final time [20]")
    args = parser.parse_args()

    model = holosym.Model.builtin("fourbar")
    run = holosym.simulate(model, M=8, h="1/160", T=args.T, every=16)
    print(f"{len(run)} rows to t = {run.t[-1]:g}: max |energy error| "
          f"{np.max(np.abs(run.energy_error)):.2e}, max |phi| "
          f"{np.max(run.constraint_residual):.2e}")
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib is not installed (pip install matplotlib): no plot",
              file=sys.stderr)
        return 0
    figure, axes = plt.subplots(2, 1, sharex=True, figsize=(7, 5))
    floor = 1e-36  # exact zeros (no error at all) drawn at the bottom, below eps
    axes[0].semilogy(run.t, np.maximum(np.abs(run.energy_error), floor), ".-")
    axes[0].set_ylabel("|H - H0| / |H0|")
    axes[1].semilogy(run.t, np.maximum(run.constraint_residual, floor), ".-")
    axes[1].set_ylabel("max |phi|")
    axes[1].set_xlabel("t")
    for axis in axes:
        axis.axhline(2.0 ** -112, color="gray", lw=0.5)  # real128 epsilon
        axis.set_ylim(bottom=floor / 2)
    figure.suptitle("four-bar linkage, (M, N, G) = (8, 7, 9), h = 1/160 (real128)")
    figure.tight_layout()
    figure.savefig(args.output, dpi=100)
    print(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
