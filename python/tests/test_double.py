"""precision="double": the real64 library of the package (libholosym64.so) against the
real64 build of `holosym simulate` to every printed digit, against the real128 library to
round-off of a double, inputs rounded once to the nearest double, and the two libraries
side by side in one process (separate handles and state)."""

from decimal import Decimal
from fractions import Fraction
import math
import os
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

import holosym
from holosym import binary64
from conftest import MODELS, csv_real, run_cli


def fields_of(header, row, prefix, n):
    return [row[header.index(f"{prefix}{i + 1}")] for i in range(n)]


def is_double(x):
    """The Decimal x is exactly a double."""
    return Decimal(float(x)) == x


# ---------------------------------------------------------------- against the real64 CLI

@pytest.mark.parametrize("case", [
    # (model, settings, python kwargs, CLI args)
    ("fourbar", {}, dict(M=8, h="1/160", T=20, every=160),
     ["--M", "8", "--h", "1/160", "--T", "20", "--every", "160"]),
    ("fourbar", dict(omega="3", g="9.8"), dict(M=4, h="1/32", T=1, every=16),
     ["--set", "omega=3", "--set", "g=9.8", "--M", "4", "--h", "1/32", "--T", "1",
      "--every", "16"]),
    ("spherical_pendulum", {}, dict(M=4, h=1 / 16, T=5, every=8),
     ["--M", "4", "--h", str(Decimal(1 / 16)), "--T", "5", "--every", "8"]),
    ("water", {}, dict(M=3, N=2, G=4, h=Fraction(1, 32), steps=40, every=10),
     ["--M", "3", "--N", "2", "--G", "4", "--h", "1/32", "--steps", "40", "--every", "10"]),
])
def test_double_agrees_with_the_real64_cli_to_every_digit(holosym_exe64, case):
    name, settings, kwargs, args = case
    model = holosym.Model.builtin(name).set(**settings)
    run = holosym.simulate(model, precision="double", **kwargs)
    assert run.precision == "double"
    header, rows = run_cli(holosym_exe64, "--model", os.path.join(MODELS, name + ".hsm"),
                           *args)
    assert len(rows) == len(run) > 2
    n = model.n
    for k, row in enumerate(rows):
        q, p = run.exact(k)
        assert all(is_double(x) for x in q + p)
        assert [csv_real(x) for x in q] == fields_of(header, row, "q", n)
        assert [csv_real(x) for x in p] == fields_of(header, row, "p", n)
        assert csv_real(run.exact_t(k)) == row[header.index("t")]
        assert csv_real(run.exact_energy(k)) == row[header.index("H")]
        # the float64 arrays are the doubles themselves
        assert run.q[k].tolist() == [float(x) for x in q]
        assert run.p[k].tolist() == [float(x) for x in p]
        cli_error = float(row[header.index("energy_error")])
        assert abs(run.energy_error[k] - cli_error) <= 1e-12 * abs(cli_error) + 1e-300
    assert run.constraint_residual[0] == float(rows[0][header.index("constraint_residual")])
    assert np.all(run.constraint_residual < 1e-12)


# ---------------------------------------------------------------- against real128

def test_double_and_quad_runs_agree_to_double_round_off():
    model = holosym.Model.builtin("fourbar")
    kwargs = dict(M=8, h="1/160", T=1, every=16)
    start = time.perf_counter()
    quad = holosym.simulate(model, **kwargs)
    middle = time.perf_counter()
    double = holosym.simulate(model, precision="double", **kwargs)
    end = time.perf_counter()
    print(f"fourbar, 160 steps of M = 8: quad {middle - start:.3f} s, "
          f"double {end - middle:.3f} s")
    assert quad.precision == "quad" and double.precision == "double"
    np.testing.assert_allclose(double.t, quad.t, rtol=1e-15, atol=0)
    assert np.max(np.abs(double.q - quad.q)) < 1e-13
    assert np.max(np.abs(double.p - quad.p)) < 1e-13
    assert np.max(np.abs(double.energy - quad.energy)) < 1e-13
    # round-off of a double, not of real128
    assert 1e-17 < np.max(np.abs(double.energy_error)) < 1e-13
    assert np.max(np.abs(quad.energy_error)) < 1e-30


def test_double_integrator_steps_observer_dense_output_and_project():
    model = holosym.Model.builtin("planar_pendulum")
    integ = holosym.Integrator(model, M=4, h="1/16", precision="double")
    assert integ.precision == "double" and "double" in repr(integ)
    reference = holosym.Integrator(model, M=4, h="1/16")
    seen = []

    def observer(step, t, q, p):
        qd, _, lam = integ.dense_output(1)
        seen.append((t, q.copy(), qd, lam))

    assert integ.integrate(16, observer=observer) == 16
    reference.integrate(16)
    assert integ.t == Fraction(1)
    assert [s[0] for s in seen] == [k / 16 for k in range(1, 17)]
    for _, q, qd, lam in seen:
        np.testing.assert_allclose(qd, q, rtol=0, atol=1e-14)
        assert lam.shape == (1,)
    q, p = integ.state
    assert all(is_double(x) for x in q + p)
    assert integ.q.tolist() == [float(x) for x in q]
    np.testing.assert_allclose(integ.q, reference.q, rtol=0, atol=1e-14)
    np.testing.assert_allclose(integ.p, reference.p, rtol=0, atol=1e-14)
    assert abs(integ.constraint()[0]) < 1e-14
    assert is_double(integ.energy(exact=True))
    integ.step()
    integ.step(Fraction(1, 8))
    assert integ.t == Fraction(19, 16)
    integ.set_state(["0.6", "-0.81"], ["0.8", "0.61"])
    integ.project()
    assert abs(integ.constraint(exact=True)[0]) < Decimal("1e-15")
    with pytest.raises(holosym.Error) as caught:
        integ.step(0)
    assert caught.value.code == holosym.INVALID_STEP_SIZE
    integ.close()
    with pytest.raises(holosym.Error) as caught:
        integ.step()
    assert caught.value.code == holosym.NOT_INITIALIZED


def test_double_ensemble_matches_single_double_runs():
    model = holosym.Model.builtin("planar_pendulum")
    states = [(["0.6", "-0.8"], ["0.8", "0.6"]), ([0, -1], ["1/2", 0])]
    result = holosym.ensemble(model, states, M=3, h="1/16", T=1, precision="double")
    assert result.precision == "double" and result.status.tolist() == [0, 0]
    for i, (q, p) in enumerate(states):
        single = holosym.Integrator(model, M=3, h="1/16", q=q, p=p, precision="double")
        single.integrate(16)
        assert result.exact(i) == single.state
        assert result.q[i].tolist() == single.q.tolist()
    assert np.all(np.abs(result.energy_error) < 1e-8)


# ---------------------------------------------------------------- inputs rounded once

def test_inputs_are_rounded_once_to_the_nearest_double():
    model = holosym.Model.builtin("planar_pendulum")
    run = holosym.simulate(model, M=2, h="0.1", steps=3, precision="double")
    assert run.h == Decimal(0.1)
    run = holosym.simulate(model, M=2, h=Fraction(1, 3), steps=3, precision="double")
    assert run.h == Decimal(1 / 3)
    # Just above the tie between 1 and 1 + 2**-52: the nearest double is 1 + 2**-52,
    # while rounding to binary128 first would give the tie itself, then 1.
    tricky = 1 + Fraction(1, 2 ** 53) + Fraction(1, 2 ** 200)
    assert binary64.to_fraction(binary64.from_value(tricky)) == 1 + Fraction(1, 2 ** 52)
    integ = holosym.Integrator(model, M=2, precision="double", q=[0, -1], p=[tricky, 0])
    assert integ.state[1][0] == Decimal(1 + 2 ** -52)
    # a parameter set on the model is rounded from the value as given, for each precision
    text = textwrap.dedent("""\
        parameters  g = 1
        coordinates x y
        momenta     px py
        hamiltonian (px^2 + py^2)/2 + g*y
        constraint  x^2 + y^2 - 1
        initial     x = 0, y = -1
        """)
    gravity = holosym.Model(text).set(g=tricky)
    double = holosym.Integrator(gravity, M=2, precision="double", q=[0, -1], p=[0, 0])
    assert double.energy(exact=True) == Decimal(-(1 + 2 ** -52))
    quad = holosym.Integrator(gravity, M=2, q=[0, -1], p=[0, 0])
    assert quad.energy(exact=True) == gravity.get("g").copy_negate()
    assert gravity.get("g") != Decimal(1 + 2 ** -52)


def test_binary64_rounding_edge_cases():
    b = binary64
    assert b.from_value("0.1") == b.from_value(0.1) == b.from_value(Fraction(1, 10))
    assert b.to_float(b.from_value(2 ** 53 + 1)) == 2.0 ** 53  # tie: to even
    assert b.to_float(b.from_value(2 ** 53 + 3)) == 2.0 ** 53 + 4
    ulp = Fraction(2) ** 971
    assert b.to_fraction(b.from_value(b.MAX + ulp / 2 - Fraction(1, 10 ** 9))) == b.MAX
    assert b.to_float(b.from_value(b.MAX + ulp / 2)) == math.inf  # tie: to even, 2**1024
    assert b.to_float(b.from_value("-1e400")) == -math.inf
    assert b.to_float(b.from_value(b.MIN_SUBNORMAL / 2)) == 0.0  # tie: to even, 0
    assert b.to_fraction(b.from_value(b.MIN_SUBNORMAL * Fraction(51, 100))) == \
        b.MIN_SUBNORMAL
    assert b.to_decimal(b.from_value("-0")) == Decimal("-0")
    assert math.copysign(1, b.to_float(b.from_value("-0"))) == -1
    assert b.to_decimal(b.from_value("inf")).is_infinite()
    assert b.to_decimal(b.from_value("nan")).is_nan()
    with pytest.raises(ValueError):
        b.to_fraction(b.from_value("nan"))
    assert b.to_decimal(b.from_value("1/3")) == Decimal(1 / 3)
    assert len(b.from_value(1)) == b.BYTES == 8


# ---------------------------------------------------------------- bad precision

@pytest.mark.parametrize("precision", ["single", "Double", "real64", None, 64])
def test_bad_precision_names_the_allowed_values(precision):
    model = holosym.Model.builtin("planar_pendulum")
    for call in (lambda: holosym.simulate(model, M=2, h="1/16", T=1, precision=precision),
                 lambda: holosym.Integrator(model, M=2, precision=precision),
                 lambda: holosym.ensemble(model, [], M=2, h="1/16", T=1,
                                          precision=precision)):
        with pytest.raises(holosym.Error) as caught:
            call()
        assert caught.value.code == holosym.INVALID_ARGUMENT == -9
        assert "'quad'" in caught.value.message and "'double'" in caught.value.message
    assert holosym.PRECISIONS == ("quad", "double")


# ---------------------------------------------------------------- two libraries

def test_the_two_libraries_are_separate():
    from holosym import _clib
    quad, double = _clib.library("quad"), _clib.library("double")
    assert quad.path != double.path and os.path.basename(double.path) == "libholosym64.so"
    assert quad.bytes == 16 and double.bytes == 8
    # each keeps its own registry of live handles: a handle of one is refused by the other
    model = holosym.Model.builtin("planar_pendulum")
    integ = holosym.Integrator(model, M=2, h="1/16")
    q, p, h = double.reals(2), double.reals(2), double.reals(1, binary64.from_value(0.0625))
    code = double.step_p(integ._handle.pointer, q.address, p.address, h.address)
    assert code == holosym.NOT_INITIALIZED
    assert integ.integrate(2) == 2  # the quad handle itself is unharmed
    # interleaved calls give what each gives alone
    alone = []
    for precision in ("quad", "double"):
        integ = holosym.Integrator(model, M=3, h="1/16", precision=precision)
        for _ in range(8):
            integ.step()
        alone.append(integ.state)
    a = holosym.Integrator(model, M=3, h="1/16")
    b = holosym.Integrator(model, M=3, h="1/16", precision="double")
    for _ in range(8):
        a.step()
        b.step()
    assert [a.state, b.state] == alone
    assert a.state != b.state


def test_a_library_loaded_globally_does_not_capture_the_other():
    """With libholosym.so in the process's global scope (RTLD_GLOBAL, as another
    package might load it), the real64 library still calls its own code."""
    script = textwrap.dedent("""\
        import ctypes, os, holosym
        from holosym import _clib
        ctypes.CDLL(_clib.library_path("quad"), mode=ctypes.RTLD_GLOBAL)
        model = holosym.Model.builtin("planar_pendulum")
        run = holosym.simulate(model, M=3, h="1/16", steps=8, precision="double")
        print(repr(run.exact(-1)))
        """)
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          check=True)
    model = holosym.Model.builtin("planar_pendulum")
    here = holosym.simulate(model, M=3, h="1/16", steps=8, precision="double")
    assert done.stdout.strip() == repr(here.exact(-1))
