#!/usr/bin/env python3
"""Independent high-precision reference solutions of two formula models:
example/models/water.hsm and example/models/fourbar.hsm.

Each model is written here again from the formulas of its model file (its Hamiltonian,
constraints and initial state, not from holosym's Fortran sources or its formula
compiler), with hand-derived derivatives; a self-test checks them against mpmath.diff
before the runs. The index-1 form is integrated with the 50-digit Gragg-Bulirsch-Stoer
extrapolation of tools/reference/model_reference.py (imported from there, with its
Model class and helpers), each macro step extrapolated until two successive diagonal
entries agree to 1e-44: water with macro steps of 1/20, then again with 1/40 (as the
catalogue's models); fourbar with 1/40, then 1/80 (with 1/20 and 1/40 the runs differed
by 2.2e-43 at T = 10, the 1/20 run needing 20 levels; a tolerance of 1e-46 does not
settle at 50 digits). The file's states are the first run's; the comments give the two
runs' difference. fourbar's states at T agree with a 64-digit run (tolerance 1e-56) to
2.4e-44, a few units of the 45th digit: the rounding errors' drift in the index-1 form
(its max|phi(q(T))| is 3e-44); water's runs agree to 1e-46.

The start states are the exact mathematical starts of the files (computed at 50 digits,
not rounded to binary128: holosym computes its own start from the file):

  water    positions and momenta as the file's `initial` line writes them (they satisfy
           both constraint levels exactly);
  fourbar  positions as written; the momenta from the `velocity` line (crank turning at
           omega, joint C at rest) as p = M v, projected onto the hidden constraint
           Phi(q) M^-1 p = 0 in the kinetic metric, as holosym's state_from_velocities
           does: p <- p - Phi^T beta, (Phi M^-1 Phi^T) beta = Phi M^-1 p.

The file holds those starts and the states at T = 10 with 45 digits.

Usage: python3 tools/reference/formula_reference.py [OUTPUT]
       (default test/data/formula_reference.csv; `make reference-formula` runs it in
       build/venv).
"""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import mpmath  # noqa: E402
from mpmath import mp, mpf  # noqa: E402

from model_reference import (DIGITS, MACRO_STEPS, SPAN, Model, dot, reference,  # noqa: E402
                             metric_gram, vec, write_reference)


def diagonal(values):
    n = len(values)
    return [[(values[i] if i == j else mpf(0)) for j in range(n)] for i in range(n)]


def zeros(n):
    return [[mpf(0)] * n for _ in range(n)]


class Water(Model):
    """example/models/water.hsm: O at q[0:3], H1 at q[3:6], H2 at q[6:9];
    H = |p_O|^2/(2 mO) + (|p_1|^2 + |p_2|^2)/(2 mH) + k/2 (angle - theta0)^2 with
    angle = acos(u1.u2/(|u1| |u2|)), u_i = r_i - r_O; phi_i = |u_i|^2 - d^2."""
    name = "water"
    n, m = 9, 2
    macro_steps = MACRO_STEPS

    def __init__(self):
        self.m_o, self.m_h, self.bond, self.k = mpf(16), mpf(1), mpf(1), mpf("0.5")
        self.theta0 = mpf("104.5") * mp.pi / 180
        self.masses = [self.m_o] * 3 + [self.m_h] * 6
        # The start: bend angle a, angular velocity (wx, wy, wz) about O.
        self.a = mpf("1.7")
        self.w = vec(["0.3", "-0.2", "0.5"])

    def start(self):
        d, m_h, a = self.bond, self.m_h, self.a
        wx, wy, wz = self.w
        hx, hy = d * mpmath.sin(a / 2), d * mpmath.cos(a / 2)
        q = [mpf(0), mpf(0), mpf(0), hx, hy, mpf(0), -hx, hy, mpf(0)]
        p = [mpf(0), mpf(0), mpf(0),
             m_h * (-wz * hy), m_h * (wz * hx), m_h * (wx * hy - wy * hx),
             m_h * (-wz * hy), m_h * (-wz * hx), m_h * (wx * hy + wy * hx)]
        return q, p

    @staticmethod
    def bonds(q):
        return [q[3 + i] - q[i] for i in range(3)], [q[6 + i] - q[i] for i in range(3)]

    def cosine(self, q):
        u1, u2 = self.bonds(q)
        r1, r2 = mpmath.sqrt(dot(u1, u1)), mpmath.sqrt(dot(u2, u2))
        return u1, u2, r1, r2, dot(u1, u2) / (r1 * r2)

    def angle(self, q):
        return mpmath.acos(self.cosine(q)[4])

    def hamiltonian(self, q, p):
        kinetic = mpmath.fsum(p[i] ** 2 / (2 * self.masses[i]) for i in range(9))
        return kinetic + self.k / 2 * (self.angle(q) - self.theta0) ** 2

    def h_q(self, q, p):
        # U = k/2 (theta - theta0)^2, theta = acos(c), c = u1.u2/(r1 r2):
        # dU/dc = -k (theta - theta0)/sqrt(1 - c^2),
        # dc/du1 = u2/(r1 r2) - c u1/r1^2, dc/du2 = u1/(r1 r2) - c u2/r2^2,
        # and u_i = r_i - r_O, so dU/dr_O = -(dU/du1 + dU/du2).
        u1, u2, r1, r2, c = self.cosine(q)
        du_dc = -self.k * (mpmath.acos(c) - self.theta0) / mpmath.sqrt(1 - c * c)
        g1 = [du_dc * (u2[i] / (r1 * r2) - c * u1[i] / r1 ** 2) for i in range(3)]
        g2 = [du_dc * (u1[i] / (r1 * r2) - c * u2[i] / r2 ** 2) for i in range(3)]
        return [-(g1[i] + g2[i]) for i in range(3)] + g1 + g2

    def h_p(self, q, p):
        return [p[i] / self.masses[i] for i in range(9)]

    def h_pp(self, q, p):
        return diagonal([1 / mass for mass in self.masses])

    def h_pq(self, q, p):
        return zeros(9)

    def phi(self, q):
        u1, u2 = self.bonds(q)
        return [dot(u1, u1) - self.bond ** 2, dot(u2, u2) - self.bond ** 2]

    def phi_jac(self, q):
        u1, u2 = self.bonds(q)
        zero = [mpf(0)] * 3
        return [[-2 * c for c in u1] + [2 * c for c in u1] + zero,
                [-2 * c for c in u2] + zero + [2 * c for c in u2]]

    def phi_curvature(self, q, v):
        # phi_i is quadratic in u_i: v^T phi_i'' v = 2 |v_i - v_O|^2.
        w1, w2 = self.bonds(v)
        return [2 * dot(w1, w1), 2 * dot(w2, w2)]


class FourBar(Model):
    """example/models/fourbar.hsm: q = (xb, yb, xc, yc);
    H = |p_B|^2/(2 m1) + |p_C|^2/(2 m2) + g (m1 yb + m2 yc); phi = (|B|^2 - a^2,
    |C - B|^2 - b^2, |C - D|^2 - c^2) with D = (d, 0)."""
    name = "fourbar"
    n, m = 4, 3
    macro_steps = tuple(2 * steps for steps in MACRO_STEPS)

    def __init__(self):
        self.a, self.b, self.c, self.d = mpf(1), mpf(3), mpf("2.5"), mpf(3)
        self.m1, self.m2, self.g = mpf(1), mpf(1), mpf(1)
        self.masses = [self.m1, self.m1, self.m2, self.m2]
        # The start: crank angle theta, crank rate omega.
        self.theta, self.omega = mpf(1), mpf(2)

    def positions(self):
        a, b, c, d = self.a, self.b, self.c, self.d
        bx, by = a * mpmath.cos(self.theta), a * mpmath.sin(self.theta)
        ex, ey = d - bx, -by
        e = mpmath.sqrt(ex ** 2 + ey ** 2)
        along = (b ** 2 - c ** 2 + e ** 2) / (2 * e)
        across = mpmath.sqrt(b ** 2 - along ** 2)
        return [bx, by, bx + (along * ex - across * ey) / e, by + (along * ey + across * ex) / e]

    def start(self):
        q = self.positions()
        bx, by = q[0], q[1]
        velocity = [-self.omega * by, self.omega * bx, mpf(0), mpf(0)]
        return q, project(self, q, [self.masses[i] * velocity[i] for i in range(4)])

    def hamiltonian(self, q, p):
        kinetic = mpmath.fsum(p[i] ** 2 / (2 * self.masses[i]) for i in range(4))
        return kinetic + self.g * (self.m1 * q[1] + self.m2 * q[3])

    def h_q(self, q, p):
        return [mpf(0), self.g * self.m1, mpf(0), self.g * self.m2]

    def h_p(self, q, p):
        return [p[i] / self.masses[i] for i in range(4)]

    def h_pp(self, q, p):
        return diagonal([1 / mass for mass in self.masses])

    def h_pq(self, q, p):
        return zeros(4)

    def phi(self, q):
        xb, yb, xc, yc = q
        return [xb ** 2 + yb ** 2 - self.a ** 2,
                (xc - xb) ** 2 + (yc - yb) ** 2 - self.b ** 2,
                (xc - self.d) ** 2 + yc ** 2 - self.c ** 2]

    def phi_jac(self, q):
        xb, yb, xc, yc = q
        dx, dy = xc - xb, yc - yb
        return [[2 * xb, 2 * yb, mpf(0), mpf(0)],
                [-2 * dx, -2 * dy, 2 * dx, 2 * dy],
                [mpf(0), mpf(0), 2 * (xc - self.d), 2 * yc]]

    def phi_curvature(self, q, v):
        vxb, vyb, vxc, vyc = v
        return [2 * (vxb ** 2 + vyb ** 2),
                2 * ((vxc - vxb) ** 2 + (vyc - vyb) ** 2),
                2 * (vxc ** 2 + vyc ** 2)]


def project(model, q, p):
    """p made tangent in the kinetic metric (H_pp = M^-1, H_p = M^-1 p): p - Phi^T beta with
    (Phi M^-1 Phi^T) beta = Phi M^-1 p."""
    n, m = model.n, model.m
    jac = model.phi_jac(q)
    hpp = model.h_pp(q, p)
    rhs = mpmath.matrix(m, 1)
    for a in range(m):
        rhs[a] = dot(jac[a], [dot(hpp[i], p) for i in range(n)])
    beta = mpmath.lu_solve(metric_gram(jac, hpp), rhs)
    return [p[i] - mpmath.fsum(jac[a][i] * beta[a] for a in range(m)) for i in range(n)]


def hidden(model, q, p):
    """max |Phi(q) H_p(q, p)|, the hidden constraint's residual."""
    v = model.h_p(q, p)
    return max(abs(dot(row, v)) for row in model.phi_jac(q))


def self_test(model):
    """The hand-derived derivatives against mpmath.diff, at the start and at a point off
    both constraint levels; the start on both levels. Raises AssertionError on a mismatch
    and returns the largest relative difference."""
    q0, p0 = model.start()
    n = model.n
    worst = mpf(0)

    def close(exact, numeric, what):
        nonlocal worst
        scale = max(1, abs(numeric))
        error = abs(exact - numeric) / scale
        worst = max(worst, error)
        assert error < mpf(10) ** -30, f"{model.name}: {what}: {exact} against {numeric}"

    def shifted(x, i, t):
        return [x[k] + (t if k == i else 0) for k in range(len(x))]

    points = [(q0, p0),
              ([x + mpmath.sin(k + 1) / 7 for k, x in enumerate(q0)],
               [x + mpmath.cos(3 * k + 1) / 5 for k, x in enumerate(p0)])]
    for q, p in points:
        hq, hp = model.h_q(q, p), model.h_p(q, p)
        hpp, hpq = model.h_pp(q, p), model.h_pq(q, p)
        jac = model.phi_jac(q)
        v = [mpmath.cos(k + 2) for k in range(n)]
        curv = model.phi_curvature(q, v)
        for i in range(n):
            close(hq[i], mpmath.diff(lambda t: model.hamiltonian(shifted(q, i, t), p), 0),
                  f"H_q[{i}]")
            close(hp[i], mpmath.diff(lambda t: model.hamiltonian(q, shifted(p, i, t)), 0),
                  f"H_p[{i}]")
            for j in range(n):
                close(hpp[i][j], mpmath.diff(lambda t: model.h_p(q, shifted(p, j, t))[i], 0),
                      f"H_pp[{i}][{j}]")
                close(hpq[i][j], mpmath.diff(lambda t: model.h_p(shifted(q, j, t), p)[i], 0),
                      f"H_pq[{i}][{j}]")
        for a in range(model.m):
            for i in range(n):
                close(jac[a][i], mpmath.diff(lambda t: model.phi(shifted(q, i, t))[a], 0),
                      f"Phi[{a}][{i}]")
            line = [lambda t, k=k: q[k] + t * v[k] for k in range(n)]
            close(curv[a], mpmath.diff(lambda t: model.phi([x(t) for x in line])[a], 0, 2),
                  f"phi''(v, v)[{a}]")
    residual = max(max(abs(c) for c in model.phi(q0)), hidden(model, q0, p0))
    assert residual < mpf(10) ** -45, f"{model.name}: the start is off the manifold"
    return worst, residual


def main():
    mp.dps = DIGITS
    output = sys.argv[1] if len(sys.argv) > 1 else "test/data/formula_reference.csv"
    models = [Water(), FourBar()]
    lines = []
    notes = []
    for model in models:
        worst, residual = self_test(model)
        print(f"# {model.name}: derivatives match mpmath.diff to {mpmath.nstr(worst, 3)}; "
              f"start on both levels to {mpmath.nstr(residual, 3)}", file=sys.stderr)
        q0, p0 = model.start()
        note, rows, (q, p) = reference(model, q0, p0, model.macro_steps, SPAN)
        print(f"# {model.name}: max|Phi(q) H_p(q, p)| at T = "
              f"{mpmath.nstr(hidden(model, q, p), 3)}", file=sys.stderr)
        notes.append(note)
        lines += rows
    header = ["Reference states of the formula models example/models/water.hsm and",
              "example/models/fourbar.hsm at T = 10 from their index-1 form, written again from",
              "the files' formulas; exact (50-digit) starts from the files, fourbar's momenta",
              "projected onto the hidden constraint in the kinetic metric; 50-digit",
              "Gragg-Bulirsch-Stoer (tools/reference/formula_reference.py, the integrator of",
              "tools/reference/model_reference.py)."]
    write_reference(output, header, notes, lines)


if __name__ == "__main__":
    main()
