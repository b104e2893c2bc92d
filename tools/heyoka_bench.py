#!/usr/bin/env python3
"""The competitor of `holosym bench`: heyoka (Taylor method, LLVM-compiled; heyoka.py on
PyPI) on the index-1 form of holosym's benchmark systems, in double or real128.

Index-1 form: Cartesian coordinates q, velocities v = M^-1 p, and the multipliers from the
twice-differentiated constraint,
    q' = v,   M v' = -grad U(q) - Phi(q)^T lambda,
    (Phi M^-1 Phi^T) lambda = phi''(q)[v, v] - Phi M^-1 grad U(q),
so phi(q(t)) = 0 holds only as far as the integration error lets it (no projection).
H, the constraints and the parameters are those of holosym's models
(src/problem/holosym_models.f90); the initial states and the reference states at T are
read from the bench's reference.csv, so both codes start from the same numbers and are
measured against the same reference.

For every tolerance of a sweep: build the integrator (compile time, reported apart),
propagate to T (CPU seconds of `propagate_until`, median of 3 for short runs), error
max(|q - q_ref|, |p - p_ref|) at T, then an untimed pass over a grid of output times for
the whole-run max |phi|, max |Phi H_p| and max relative energy error.

Usage:
  heyoka_bench.py sweep --system S --precision real128|real64 --reference FILE --out CSV
                  [--budget S] [--quick]
  heyoka_bench.py long --system S --span T --reference FILE --out CSV --tolerances LIST
Rows are appended to CSV in the format of holosym's bench.csv (method 'heyoka'; h is the
mean step T/steps, order the Taylor order); `long` writes the columns of long.csv. A run
whose error or residuals are not finite (a blow-up) is reported on stderr and gets no
row: holosym reads these files strictly and refuses NaN and Inf.
"""
import argparse
import csv
import math
import os
import statistics
import sys
import time

import heyoka as hy
import numpy

BENCH_HEADER = ("system,method,precision,M,N,G,order,h,steps,error,energy_error,"
                "constraint_residual,seconds,seconds_per_step,newton_iterations,"
                "residual_evaluations,gradient_evaluations,hessian_evaluations,"
                "lu_factorizations,status,difference_from_plain,tolerance,compile_seconds")
LONG_HEADER = ("system,method,precision,span,config,tolerance,steps,error,max_phi,"
               "max_hidden,energy_error,seconds,compile_seconds,status")
SPANS = {"pendulum": 10, "linkage": 10, "planar": 100}
SHORT_RUN = 0.2  # seconds: shorter runs are repeated three times, the median kept


def solve3(a, b):
    """Cramer's rule for a 3 x 3 system of heyoka expressions."""
    def det(m):
        return (m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
                - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
                + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]))
    d = det(a)
    result = []
    for column in range(3):
        m = [[b[r] if c == column else a[r][c] for c in range(3)] for r in range(3)]
        result.append(det(m) / d)
    return result


class Model:
    """H = sum p_i^2 / (2 m_i) + U(q), constraints phi(q) = 0 (quadratic in q)."""

    def __init__(self, name, fp):
        self.name = name
        self.fp = fp
        if name == "pendulum":      # spherical pendulum, mass 1, length 1
            self.n, self.m = 3, 1
        elif name == "planar":      # planar pendulum, H = |p|^2/2 + q_2
            self.n, self.m = 2, 1
        elif name == "linkage":     # spring-linkage, m = m_r = 1, k = 1, D = 1, ...
            self.n, self.m = 6, 3
        else:
            raise ValueError("unknown system " + name)
        self.masses = [1.0] * self.n
        self.q = list(hy.make_vars(*["q%d" % i for i in range(self.n)]))
        self.v = list(hy.make_vars(*["v%d" % i for i in range(self.n)]))

    def c(self, x):
        """A constant of the working precision."""
        return hy.expression(self.fp(x)) if self.fp is not float else hy.expression(float(x))

    def potential(self, q, sin, cos):
        if self.name == "pendulum":
            return -sin(q[2])
        if self.name == "planar":
            return q[1]
        k, d, l0 = 1, 1, self.fp("0.4") if self.fp is not float else 0.4
        return k / 2 * ((q[4] + d - l0) ** 2 + (d - q[5] - l0) ** 2)

    def grad_potential(self, q):
        zero = self.c(0)
        if self.name == "pendulum":
            return [zero, zero, -hy.cos(q[2])]
        if self.name == "planar":
            return [zero, self.c(1)]
        l0 = self.c("0.4")
        return [zero, zero, zero, zero, q[4] + self.c(1) - l0, -(self.c(1) - q[5] - l0)]

    def constraints(self, q, number):
        """phi(q) with `number` the constant maker (works on expressions and numbers)."""
        if self.name in ("pendulum", "planar"):
            return [sum(x * x for x in q) - number(1)]
        r, l = number("0.2"), number("0.8")
        return [(q[0] - q[4]) ** 2 + q[1] ** 2 - r * r,
                (q[2] - q[5]) ** 2 + q[3] ** 2 - r * r,
                (q[2] - q[0]) ** 2 + (q[3] - q[1]) ** 2 - l * l]

    def jacobian(self, q, number):
        """Phi(q), m rows of n entries."""
        zero = number(0)
        if self.name in ("pendulum", "planar"):
            return [[2 * x for x in q]]
        a, b = q[0] - q[4], q[2] - q[5]
        dx, dy = q[2] - q[0], q[3] - q[1]
        return [[2 * a, 2 * q[1], zero, zero, -2 * a, zero],
                [zero, zero, 2 * b, 2 * q[3], zero, -2 * b],
                [-2 * dx, -2 * dy, 2 * dx, 2 * dy, zero, zero]]

    def curvature(self, v):
        """phi''(q)[v, v] (constant second derivatives)."""
        if self.name in ("pendulum", "planar"):
            return [2 * sum(x * x for x in v)]
        return [2 * (v[0] - v[4]) ** 2 + 2 * v[1] ** 2,
                2 * (v[2] - v[5]) ** 2 + 2 * v[3] ** 2,
                2 * (v[2] - v[0]) ** 2 + 2 * (v[3] - v[1]) ** 2]

    def equations(self):
        q, v = self.q, self.v
        jac = self.jacobian(q, self.c)
        grad = self.grad_potential(q)
        inv_m = [self.c(1) / self.c(mass) for mass in self.masses]
        rhs = [self.curvature(v)[l]
               - sum(jac[l][i] * inv_m[i] * grad[i] for i in range(self.n))
               for l in range(self.m)]
        a = [[sum(jac[l][i] * inv_m[i] * jac[k][i] for i in range(self.n))
              for k in range(self.m)] for l in range(self.m)]
        if self.m == 1:
            lam = [rhs[0] / a[0][0]]
        else:
            lam = solve3(a, rhs)
        accel = [inv_m[i] * (-grad[i] - sum(jac[l][i] * lam[l] for l in range(self.m)))
                 for i in range(self.n)]
        return [(q[i], v[i]) for i in range(self.n)] + \
            [(v[i], accel[i]) for i in range(self.n)]

    def energy(self, state):
        n = self.n
        kinetic = sum(self.masses[i] * state[n + i] ** 2 for i in range(n)) / 2
        return kinetic + self.potential(state[:n], self.num_sin, self.num_cos)

    # Numbers of the working precision for the diagnostics.
    def num(self, x):
        return self.fp(x) if self.fp is not float else float(x)

    @staticmethod
    def num_sin(x):
        return numpy.sin(x)

    @staticmethod
    def num_cos(x):
        return numpy.cos(x)

    def residuals(self, state):
        """max |phi| and max |Phi H_p| of a state (q, v)."""
        n = self.n
        q, v = list(state[:n]), list(state[n:])
        phi = self.constraints(q, self.num)
        jac = self.jacobian(q, self.num)
        hidden = [sum(jac[l][i] * v[i] for i in range(n)) for l in range(self.m)]
        return max(abs(x) for x in phi), max(abs(x) for x in hidden)


def read_reference(path, system, fp):
    """q0, p0 (initial state) and q_ref, p_ref (state at T) of `system`."""
    values = {}
    with open(path) as handle:
        for line in handle:
            if line.startswith("#"):
                continue
            fields = line.strip().split(",")
            if len(fields) != 4 or fields[0] != system:
                continue
            values[(fields[1], int(fields[2]))] = fp(fields[3])
    def vector(kind):
        count = sum(1 for key in values if key[0] == kind)
        if count == 0:
            sys.exit("heyoka_bench: %s has no '%s' values of %s" % (path, kind, system))
        return [values[(kind, i)] for i in range(1, count + 1)]
    return vector("q0"), vector("p0"), vector("q"), vector("p")


def finite(*values):
    """Whether every value (float or real128) is finite."""
    return all(math.isfinite(float(x)) for x in values)


def text(x):
    """A number as holosym's CSV reader takes it (36 digits in real128, 17 in double)."""
    if isinstance(x, hy.real128):
        return str(x)
    return repr(float(x))


class Runner:
    def __init__(self, model, precision, q0, p0, span):
        self.model = model
        self.precision = precision
        self.fp = model.fp
        self.span = self.fp(str(span)) if self.fp is not float else float(span)
        n = model.n
        self.x0 = list(q0) + [p0[i] / model.num(model.masses[i]) for i in range(n)]
        self.energy0 = model.energy(self.x0)
        self.sys = model.equations()

    def build(self, tolerance):
        start = time.process_time()
        kwargs = {"tol": self.fp(tolerance) if self.fp is not float else float(tolerance)}
        if self.fp is not float:
            kwargs["fp_type"] = self.fp
        ta = hy.taylor_adaptive(self.sys, [self.fp(0) if self.fp is not float else 0.0]
                                * len(self.x0), **kwargs)
        return ta, time.process_time() - start

    def reset(self, ta):
        ta.time = self.fp(0) if self.fp is not float else 0.0
        for i, x in enumerate(self.x0):
            ta.state[i] = x

    def timed(self, ta):
        """CPU seconds to T (median of 3 under SHORT_RUN), steps, final state."""
        times = []
        while True:
            self.reset(ta)
            start = time.process_time()
            result = ta.propagate_until(self.span)
            times.append(time.process_time() - start)
            if len(times) == 3 or times[0] >= SHORT_RUN:
                break
        return statistics.median(times), int(result[3]), list(ta.state), str(result[0])

    def diagnose(self, ta, points):
        """Whole-run max |phi|, max |Phi H_p| and max relative energy error on a grid."""
        self.reset(ta)
        if self.fp is float:
            grid = [self.span * k / (points - 1) for k in range(points)]
        else:
            grid = [self.span * self.fp(k) / self.fp(points - 1) for k in range(points)]
        result = ta.propagate_grid(numpy.array(grid, dtype=type(grid[1])))
        states = result[-1]
        max_phi = max_hidden = energy_error = 0
        for row in states:
            row = list(row)
            phi, hidden = self.model.residuals(row)
            max_phi = max(max_phi, phi)
            max_hidden = max(max_hidden, hidden)
            energy_error = max(energy_error,
                               abs((self.model.energy(row) - self.energy0) / self.energy0))
        return max_phi, max_hidden, energy_error

    def error(self, state, q_ref, p_ref):
        n = self.model.n
        q = state[:n]
        p = [self.model.num(self.model.masses[i]) * state[n + i] for i in range(n)]
        return max(max(abs(q[i] - q_ref[i]) for i in range(n)),
                   max(abs(p[i] - p_ref[i]) for i in range(n)))


def sweep(args):
    fp = hy.real128 if args.precision == "real128" else float
    model = Model(args.system, fp)
    q0, p0, q_ref, p_ref = read_reference(args.reference, args.system, fp)
    runner = Runner(model, args.precision, q0, p0, SPANS[args.system])
    if args.precision == "real128":
        exponents = list(range(4, 35)) if not args.quick else [6, 10, 14]
    else:
        exponents = list(range(4, 17)) if not args.quick else [6, 10]
    new_file = not os.path.exists(args.out)
    best, no_gain = None, 0
    with open(args.out, "a", newline="") as handle:
        if new_file:
            handle.write(BENCH_HEADER + "\n")
        for exponent in exponents:
            tolerance = "1e-%d" % exponent
            ta, compile_seconds = runner.build(tolerance)
            seconds, steps, state, outcome = runner.timed(ta)
            error = runner.error(state, q_ref, p_ref)
            max_phi, max_hidden, energy_error = runner.diagnose(ta, args.grid)
            status = 0 if "time_limit" in outcome else 1
            if not finite(error, max_phi, max_hidden, energy_error):
                print("heyoka: %s %s tol %s: a non-finite error or residual, no row"
                      % (args.system, args.precision, tolerance), file=sys.stderr)
                continue
            row = [args.system, "heyoka", args.precision, 0, 0, 0, ta.order,
                   text(runner.span / steps), steps, text(error), text(energy_error),
                   text(max(max_phi, max_hidden)), repr(seconds), repr(seconds / steps),
                   0, 0, 0, 0, 0, status, text(fp(0) if fp is not float else 0.0),
                   text(fp(tolerance) if fp is not float else float(tolerance)),
                   repr(compile_seconds)]
            handle.write(",".join(str(x) for x in row) + "\n")
            handle.flush()
            print("heyoka: %s %s tol %s order %d: error %.3e, %.3e s (compile %.2f s)"
                  % (args.system, args.precision, tolerance, ta.order, float(error), seconds,
                     compile_seconds), file=sys.stderr)
            if seconds > args.budget or float(error) < 1e-32:
                break
            if best is not None and float(error) >= 0.9 * best:
                no_gain += 1
                if no_gain >= 2:
                    break
            else:
                no_gain = 0
            best = float(error) if best is None else min(best, float(error))


def long_runs(args):
    fp = hy.real128
    model = Model(args.system, fp)
    q0, p0, q_ref, p_ref = read_reference(args.reference, args.system, fp)
    runner = Runner(model, "real128", q0, p0, args.span)
    new_file = not os.path.exists(args.out)
    with open(args.out, "a", newline="") as handle:
        if new_file:
            handle.write(LONG_HEADER + "\n")
        for tolerance in args.tolerances.split(","):
            ta, compile_seconds = runner.build(tolerance)
            seconds, steps, state, outcome = runner.timed(ta)
            error = runner.error(state, q_ref, p_ref)
            max_phi, max_hidden, energy_error = runner.diagnose(ta, args.grid)
            status = 0 if "time_limit" in outcome else 1
            if not finite(error, max_phi, max_hidden, energy_error):
                print("heyoka long: %s T = %s tol %s: a non-finite error or residual, no row"
                      % (args.system, args.span, tolerance), file=sys.stderr)
                continue
            row = [args.system, "heyoka", "real128", args.span, "order %d" % ta.order,
                   text(fp(tolerance)), steps, text(error), text(max_phi), text(max_hidden),
                   text(energy_error), repr(seconds), repr(compile_seconds), status]
            handle.write(",".join(str(x) for x in row) + "\n")
            handle.flush()
            print("heyoka long: %s T = %s tol %s: error %.3e, max|phi| %.2e, %.3e s"
                  % (args.system, args.span, tolerance, float(error), float(max_phi),
                     seconds), file=sys.stderr)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = parser.add_subparsers(dest="mode", required=True)
    one = sub.add_parser("sweep")
    one.add_argument("--system", required=True, choices=sorted(SPANS))
    one.add_argument("--precision", required=True, choices=["real128", "real64"])
    one.add_argument("--reference", required=True)
    one.add_argument("--out", required=True)
    one.add_argument("--budget", type=float, default=1.5)
    one.add_argument("--grid", type=int, default=1001)
    one.add_argument("--quick", action="store_true")
    two = sub.add_parser("long")
    two.add_argument("--system", required=True, choices=sorted(SPANS))
    two.add_argument("--span", required=True)
    two.add_argument("--reference", required=True)
    two.add_argument("--out", required=True)
    two.add_argument("--tolerances", required=True)
    two.add_argument("--grid", type=int, default=10001)
    args = parser.parse_args()
    if args.mode == "sweep":
        sweep(args)
    else:
        long_runs(args)


if __name__ == "__main__":
    main()
