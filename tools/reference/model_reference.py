#!/usr/bin/env python3
"""Independent high-precision reference solutions of holosym's model catalogue.

Each model is written here again from its formulas (not from the Fortran sources) and its
index-1 form is integrated with 50-digit arithmetic (mpmath):

    q' = H_p,   p' = -H_q - Phi^T lambda,
    (Phi H_pp Phi^T) lambda = phi''(v, v) + Phi H_pq v - Phi H_pp H_q,   v = H_p,

which follows from differentiating the hidden constraint Phi(q) H_p(q, p) = 0 once more
(phi''(v, v)_l = v^T (d2 phi_l / dq2) v, H_pq = dH_p/dq). The integrator is the
Gragg-Bulirsch-Stoer extrapolation of the explicit midpoint rule: macro steps of 1/20,
each extrapolated in h^2 until two successive diagonal entries agree to 1e-44. The run is
repeated with macro steps of 1/40; the two agree to far below 1e-30 (written to the file's
comments), and H and phi are conserved to the same level.

The start states are the models' documented initial states rounded to binary128 (113-bit
significands, as holosym holds them), so holosym and this script start from the same
numbers; the file holds those starts and the states at T = 10 with 45 digits.

Usage: python3 tools/reference/model_reference.py [OUTPUT]
       (default test/data/model_reference.csv; `make reference` runs it in build/venv).
tools/reference/formula_reference.py imports the integrator (solve, reference) and the
CSV writer (write_reference) from here.
"""
import sys
import time

import mpmath
from mpmath import mp, mpf

DIGITS = 50
SPAN = 10
MACRO_STEPS = (200, 400)
TOLERANCE = mpf(10) ** -44
MAX_LEVELS = 40


def vec(values):
    return [mpf(v) for v in values]


def dot(a, b):
    return mpmath.fsum(x * y for x, y in zip(a, b))


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def to_binary128(x):
    """x rounded to a 113-bit significand (binary128 has the same, and the exponents of the
    states here are far inside its range)."""
    with mpmath.workprec(113):
        return +mpf(x)


def metric_gram(jac, hpp):
    """Phi H_pp Phi^T, the constraints' Gram matrix in the kinetic metric."""
    m, n = len(jac), len(hpp)
    matrix = mpmath.matrix(m, m)
    for a in range(m):
        hpp_phia = [dot(hpp[i], jac[a]) for i in range(n)]
        for b in range(m):
            matrix[b, a] = dot(jac[b], hpp_phia)
    return matrix


class Model:
    """A model: n, m, H, its derivatives and the constraints, written in plain formulas."""
    name = ""

    def index1(self, q, p):
        """Right-hand side of the index-1 form."""
        n, m = self.n, self.m
        hq = self.h_q(q, p)
        v = self.h_p(q, p)
        hpp = self.h_pp(q, p)
        hpq = self.h_pq(q, p)
        jac = self.phi_jac(q)
        curv = self.phi_curvature(q, v)
        hpq_v = [dot(hpq[i], v) for i in range(n)]
        hpp_hq = [dot(hpp[i], hq) for i in range(n)]
        rhs = mpmath.matrix(m, 1)
        for a in range(m):
            rhs[a] = curv[a] + dot(jac[a], hpq_v) - dot(jac[a], hpp_hq)
        lam = mpmath.lu_solve(metric_gram(jac, hpp), rhs)
        force = [-hq[i] - mpmath.fsum(jac[a][i] * lam[a] for a in range(m)) for i in range(n)]
        return v, force


class DoublePendulum(Model):
    """pendulum_chain(2, masses=[1, 2], lengths=[1, 0.7]), g = 1, from angles (1, 0.5) at
    rest: q = (x1, y1, x2, y2)."""
    name = "double"

    def __init__(self, masses=(1, 2), lengths=(1, "0.7"), angles=(1, "0.5"),
                 rates=(0, 0), name="double"):
        # Numbers as text: converted at the working precision in force when called.
        self.name = name
        self.k = len(masses)
        self.n, self.m = 2 * self.k, self.k
        self.masses = vec(masses)
        # The parameters as holosym holds them (0.7 is not a binary number).
        self.lengths = [to_binary128(l) for l in vec(lengths)]
        self.angles = vec(angles)
        self.rates = vec(rates)
        self.g = mpf(1)

    def start(self):
        # The real128 start of state_from_angles: the angles are binary128 numbers.
        angles = [to_binary128(a) for a in self.angles]
        lengths = self.lengths
        q, p = [], []
        r = [mpf(0), mpf(0)]
        v = [mpf(0), mpf(0)]
        for k in range(self.k):
            r = [r[0] + lengths[k] * mpmath.sin(angles[k]),
                 r[1] - lengths[k] * mpmath.cos(angles[k])]
            v = [v[0] + lengths[k] * self.rates[k] * mpmath.cos(angles[k]),
                 v[1] + lengths[k] * self.rates[k] * mpmath.sin(angles[k])]
            q += r
            p += [self.masses[k] * v[0], self.masses[k] * v[1]]
        return q, p

    def hamiltonian(self, q, p):
        return mpmath.fsum((p[2 * k] ** 2 + p[2 * k + 1] ** 2) / (2 * self.masses[k])
                           + self.g * self.masses[k] * q[2 * k + 1] for k in range(self.k))

    def h_q(self, q, p):
        out = []
        for k in range(self.k):
            out += [mpf(0), self.g * self.masses[k]]
        return out

    def h_p(self, q, p):
        return [p[i] / self.masses[i // 2] for i in range(self.n)]

    def h_pp(self, q, p):
        return [[(1 / self.masses[i // 2] if i == j else mpf(0)) for j in range(self.n)]
                for i in range(self.n)]

    def h_pq(self, q, p):
        return [[mpf(0)] * self.n for _ in range(self.n)]

    def link(self, q, k):
        d = [q[2 * k], q[2 * k + 1]]
        if k > 0:
            d = [d[0] - q[2 * k - 2], d[1] - q[2 * k - 1]]
        return d

    def phi(self, q):
        return [dot(self.link(q, k), self.link(q, k)) - self.lengths[k] ** 2
                for k in range(self.k)]

    def phi_jac(self, q):
        rows = []
        for k in range(self.k):
            row = [mpf(0)] * self.n
            d = self.link(q, k)
            row[2 * k], row[2 * k + 1] = 2 * d[0], 2 * d[1]
            if k > 0:
                row[2 * k - 2], row[2 * k - 1] = -2 * d[0], -2 * d[1]
            rows.append(row)
        return rows

    def phi_curvature(self, q, v):
        return [2 * dot(self.link(v, k), self.link(v, k)) for k in range(self.k)]


class Dumbbell(Model):
    """sphere_dumbbell(): masses (1, 2), R = 1, L = 1, g = 1; u = (3/5, 0, -4/5),
    e = (0, 1, 0), omega = (0.3, -0.5, 0.8)."""
    name = "dumbbell"
    n, m = 6, 3

    def __init__(self):
        self.masses = vec([1, 2])
        self.radius = mpf(1)
        self.rod = mpf(1)
        self.g = mpf(1)

    def start(self):
        u = [to_binary128(mpf(3) / 5), mpf(0), to_binary128(-mpf(4) / 5)]
        omega = [to_binary128(mpf(3) / 10), to_binary128(-mpf(1) / 2),
                 to_binary128(mpf(8) / 10)]
        half_sin = self.rod / (2 * self.radius)
        half_cos = to_binary128(mpmath.sqrt((1 - half_sin) * (1 + half_sin)))
        e = [mpf(0), mpf(1), mpf(0)]
        r1 = [to_binary128(self.radius * (half_cos * u[i] + half_sin * e[i])) for i in range(3)]
        r2 = [to_binary128(self.radius * (half_cos * u[i] - half_sin * e[i])) for i in range(3)]
        p1 = [self.masses[0] * c for c in cross(omega, r1)]
        p2 = [self.masses[1] * c for c in cross(omega, r2)]
        return r1 + r2, p1 + p2

    def hamiltonian(self, q, p):
        return (dot(p[:3], p[:3]) / (2 * self.masses[0]) + dot(p[3:], p[3:]) / (2 * self.masses[1])
                + self.g * (self.masses[0] * q[2] + self.masses[1] * q[5]))

    def h_q(self, q, p):
        return [0, 0, self.g * self.masses[0], 0, 0, self.g * self.masses[1]]

    def h_p(self, q, p):
        return [p[i] / self.masses[i // 3] for i in range(6)]

    def h_pp(self, q, p):
        return [[(1 / self.masses[i // 3] if i == j else mpf(0)) for j in range(6)]
                for i in range(6)]

    def h_pq(self, q, p):
        return [[mpf(0)] * 6 for _ in range(6)]

    def phi(self, q):
        d = [q[i] - q[i + 3] for i in range(3)]
        return [dot(q[:3], q[:3]) - self.radius ** 2, dot(q[3:], q[3:]) - self.radius ** 2,
                dot(d, d) - self.rod ** 2]

    def phi_jac(self, q):
        d = [q[i] - q[i + 3] for i in range(3)]
        return [[2 * q[0], 2 * q[1], 2 * q[2], 0, 0, 0],
                [0, 0, 0, 2 * q[3], 2 * q[4], 2 * q[5]],
                [2 * d[0], 2 * d[1], 2 * d[2], -2 * d[0], -2 * d[1], -2 * d[2]]]

    def phi_curvature(self, q, v):
        dv = [v[i] - v[i + 3] for i in range(3)]
        return [2 * dot(v[:3], v[:3]), 2 * dot(v[3:], v[3:]), 2 * dot(dv, dv)]


class Magnetic(Model):
    """magnetic_sphere(): mass 1, B = 2, g = 1, R = 1; q = (3/5, 0, -4/5),
    v = omega x q with omega = (0.2, 1.0, -0.3), p = v + A(q)."""
    name = "magnetic"
    n, m = 3, 1

    def __init__(self):
        self.mass = mpf(1)
        self.field = mpf(2)
        self.g = mpf(1)
        self.radius = mpf(1)

    def potential(self, q):
        return [-self.field / 2 * q[1], self.field / 2 * q[0], mpf(0)]

    def start(self):
        q = [to_binary128(mpf(3) / 5), mpf(0), to_binary128(-mpf(4) / 5)]
        omega = [to_binary128(mpf(2) / 10), mpf(1), to_binary128(-mpf(3) / 10)]
        v = cross(omega, q)
        a = self.potential(q)
        return q, [self.mass * v[i] + a[i] for i in range(3)]

    def velocity(self, q, p):
        a = self.potential(q)
        return [(p[i] - a[i]) / self.mass for i in range(3)]

    def hamiltonian(self, q, p):
        v = self.velocity(q, p)
        return self.mass * dot(v, v) / 2 + self.mass * self.g * q[2]

    def h_q(self, q, p):
        v = self.velocity(q, p)
        return [-self.field / 2 * v[1], self.field / 2 * v[0], self.mass * self.g]

    def h_p(self, q, p):
        return self.velocity(q, p)

    def h_pp(self, q, p):
        return [[(1 / self.mass if i == j else mpf(0)) for j in range(3)] for i in range(3)]

    def h_pq(self, q, p):
        # d/dq of (p - A(q))/mass: -dA/dq / mass.
        b = self.field / 2 / self.mass
        return [[0, b, 0], [-b, 0, 0], [0, 0, 0]]

    def phi(self, q):
        return [dot(q, q) - self.radius ** 2]

    def phi_jac(self, q):
        return [[2 * c for c in q]]

    def phi_curvature(self, q, v):
        return [2 * dot(v, v)]


class Generic(Model):
    """generic_pendulum(): m = 1, R = 1, g = 1, U = g z + 0.2 x^2 + 0.3 x y + 0.25 y z
    + 0.1 sin(x + 2 y); q = (3/5, 0, -4/5), p = (0.4, 0.5, 0.3)."""
    name = "generic"
    n, m = 3, 1

    def __init__(self):
        self.mass = mpf(1)
        self.radius = mpf(1)
        self.g = mpf(1)
        self.k = [to_binary128(mpf(c) / 100) for c in (20, 30, 25, 10)]

    def start(self):
        q = [to_binary128(mpf(3) / 5), mpf(0), to_binary128(-mpf(4) / 5)]
        p = [to_binary128(mpf(c) / 10) for c in (4, 5, 3)]
        return q, p

    def hamiltonian(self, q, p):
        x, y, z = q
        a, b, c, d = self.k
        return (dot(p, p) / (2 * self.mass) + self.mass * self.g * z + a * x ** 2 + b * x * y
                + c * y * z + d * mpmath.sin(x + 2 * y))

    def h_q(self, q, p):
        x, y, z = q
        a, b, c, d = self.k
        wave = d * mpmath.cos(x + 2 * y)
        return [2 * a * x + b * y + wave, b * x + c * z + 2 * wave, self.mass * self.g + c * y]

    def h_p(self, q, p):
        return [c / self.mass for c in p]

    def h_pp(self, q, p):
        return [[(1 / self.mass if i == j else mpf(0)) for j in range(3)] for i in range(3)]

    def h_pq(self, q, p):
        return [[mpf(0)] * 3 for _ in range(3)]

    def phi(self, q):
        return [dot(q, q) - self.radius ** 2]

    def phi_jac(self, q):
        return [[2 * c for c in q]]

    def phi_curvature(self, q, v):
        return [2 * dot(v, v)]


def midpoint(model, q, p, step, substeps):
    """Gragg's modified midpoint rule over one macro step."""
    n = model.n
    h = step / substeps
    y0 = q + p

    def f(y):
        dq, dp = model.index1(y[:n], y[n:])
        return dq + dp

    z_prev = y0
    dy = f(y0)
    z = [y0[i] + h * dy[i] for i in range(2 * n)]
    for _ in range(substeps - 1):
        dy = f(z)
        z_prev, z = z, [z_prev[i] + 2 * h * dy[i] for i in range(2 * n)]
    dy = f(z)
    return [(z[i] + z_prev[i] + h * dy[i]) / 2 for i in range(2 * n)]


def gbs_step(model, q, p, step, tolerance=None, max_levels=None):
    """One extrapolated macro step: Aitken-Neville in h^2 on n_j = 2 j substeps, until two
    successive diagonal entries agree to tolerance (default TOLERANCE) within max_levels
    (default MAX_LEVELS) levels."""
    tolerance = TOLERANCE if tolerance is None else tolerance
    max_levels = MAX_LEVELS if max_levels is None else max_levels
    table = []
    counts = []
    for level in range(1, max_levels + 1):
        counts.append(2 * level)
        row = [midpoint(model, q, p, step, counts[-1])]
        for k in range(1, level):
            ratio = (mpf(counts[-1]) / counts[-1 - k]) ** 2 - 1
            row.append([row[k - 1][i] + (row[k - 1][i] - table[-1][k - 1][i]) / ratio
                        for i in range(len(row[0]))])
        if level > 1:
            change = max(abs(row[-1][i] - table[-1][-1][i]) for i in range(len(row[0])))
            if change < tolerance:
                y = row[-1]
                return y[:model.n], y[model.n:], level
        table.append(row)
    raise RuntimeError(f"{model.name}: extrapolation did not settle in {max_levels} levels")


def solve(model, q0, p0, steps, span=None, tolerance=None, max_levels=None):
    """(q, p) at T = span (default SPAN) after `steps` equal macro steps, and the most
    levels a macro step used."""
    span = SPAN if span is None else span
    q, p = list(q0), list(p0)
    step = mpf(span) / steps
    levels = 0
    for _ in range(steps):
        q, p, used = gbs_step(model, q, p, step, tolerance, max_levels)
        levels = max(levels, used)
    return q, p, levels


def fmt(x):
    return mpmath.nstr(x, 45, min_fixed=1, max_fixed=0, strip_zeros=False)


def reference(model, q0, p0, macro_steps=None, span=None, tolerance=None, max_levels=None):
    """The reference of one model from (q0, p0) (used as given): solved to T = span with
    each count of macro_steps (default MACRO_STEPS, SPAN); returns the comment line (the
    runs' difference, |H(T) - H(0)|, max|phi(q(T))|, levels, seconds) and the CSV rows
    (q0, p0, qT, pT of the first run, H0), and the first run's (q, p) at T; prints the
    comment line to stderr."""
    macro_steps = MACRO_STEPS if macro_steps is None else macro_steps
    span = SPAN if span is None else span
    started = time.time()
    results = [solve(model, q0, p0, steps, span, tolerance, max_levels)
               for steps in macro_steps]
    (q, p, levels), (q2, p2, _) = results
    change = max(abs(a - b) for a, b in zip(q + p, q2 + p2))
    energy0 = model.hamiltonian(q0, p0)
    drift = abs(model.hamiltonian(q, p) - energy0)
    phi_end = max(abs(c) for c in model.phi(q))
    note = (f"# {model.name}: macro steps 1/{macro_steps[0] // span} and "
            f"1/{macro_steps[1] // span} differ by {mpmath.nstr(change, 3)}; "
            f"|H(T) - H(0)| = {mpmath.nstr(drift, 3)}; max|phi(q(T))| = "
            f"{mpmath.nstr(phi_end, 3)}; {levels} levels; "
            f"{time.time() - started:.0f} s")
    print(note, file=sys.stderr)
    rows = []
    for label, values in (("q0", q0), ("p0", p0), ("qT", q), ("pT", p)):
        for i, value in enumerate(values, start=1):
            rows.append(f"{model.name},{label},{i},{fmt(value)}")
    rows.append(f"{model.name},H0,1,{fmt(energy0)}")
    return note, rows, (q, p)


def write_reference(output, header, notes, rows):
    """The CSV file: the header's lines and the notes as '#' comments, then the rows."""
    with open(output, "w") as handle:
        for line in header:
            handle.write("# " + line + "\n")
        for note in notes:
            handle.write(note + "\n")
        handle.write("system,quantity,index,value\n")
        handle.write("\n".join(rows) + "\n")


def main():
    mp.dps = DIGITS
    output = sys.argv[1] if len(sys.argv) > 1 else "test/data/model_reference.csv"
    models = [DoublePendulum(), Dumbbell(), Magnetic(), Generic(),
              DoublePendulum(masses=(1, 1, 1, 1), lengths=(1, 1, 1, 1),
                             angles=("0.5", "0.4", "0.3", "0.2"),
                             rates=(0, 0, 0, 0), name="chain4")]
    lines = []
    notes = []
    for model in models:
        q0, p0 = model.start()
        q0 = [to_binary128(c) for c in q0]
        p0 = [to_binary128(c) for c in p0]
        note, rows, _ = reference(model, q0, p0)
        notes.append(note)
        lines += rows
    header = ["Reference states of holosym's models at T = 10 from their index-1 form,",
              "50-digit Gragg-Bulirsch-Stoer (tools/reference/model_reference.py)."]
    write_reference(output, header, notes, lines)


if __name__ == "__main__":
    main()
