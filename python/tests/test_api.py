"""The Python API over the C interface: models, simulate (against `holosym simulate` to
every printed digit), the step-by-step Integrator, ensembles, and every kind of bad
input (codes and messages of the library, state unchanged)."""

from decimal import Decimal
from fractions import Fraction
import os
import re

import numpy as np
import pytest

import holosym
from holosym import binary128
from conftest import MODELS, csv_real, run_cli


def fields_of(header, row, prefix, n):
    return [row[header.index(f"{prefix}{i + 1}")] for i in range(n)]


# ---------------------------------------------------------------- against the CLI

@pytest.mark.parametrize("case", [
    # (model, python kwargs, CLI args)
    ("fourbar", dict(M=8, h="1/160", T=20, every=160), ["--M", "8", "--h", "1/160",
                                                       "--T", "20", "--every", "160"]),
    ("spherical_pendulum", dict(M=4, h=1 / 16, T=5, every=8),
     ["--M", "4", "--h", str(Decimal(1 / 16)), "--T", "5", "--every", "8"]),
    ("water", dict(M=3, N=2, G=4, h=Fraction(1, 32), steps=40, every=10),
     ["--M", "3", "--N", "2", "--G", "4", "--h", "1/32", "--steps", "40", "--every", "10"]),
])
def test_simulate_agrees_with_the_cli_to_every_digit(holosym_exe, case):
    name, kwargs, args = case
    model = holosym.Model.builtin(name)
    run = holosym.simulate(model, **kwargs)
    header, rows = run_cli(holosym_exe, "--model", os.path.join(MODELS, name + ".hsm"), *args)
    assert len(rows) == len(run) > 2
    n = model.n
    for k, row in enumerate(rows):
        q, p = run.exact(k)
        assert [csv_real(x) for x in q] == fields_of(header, row, "q", n)
        assert [csv_real(x) for x in p] == fields_of(header, row, "p", n)
        assert csv_real(run.exact_t(k)) == row[header.index("t")]
        assert csv_real(run.exact_energy(k)) == row[header.index("H")]
        assert run.t[k] == float(row[header.index("t")])
        cli_error = float(row[header.index("energy_error")])
        assert abs(run.energy_error[k] - cli_error) <= 1e-12 * abs(cli_error) + 1e-300
    # t = 0: both residuals are max|phi(q0)|; later rows: the CLI's is over the step's
    # nodes, ours at the row's state; both at round-off of real128.
    assert run.constraint_residual[0] == float(rows[0][header.index("constraint_residual")])
    assert np.all(run.constraint_residual < 1e-28)


def test_parameters_set_by_name_agree_with_the_cli(holosym_exe):
    model = holosym.Model.builtin("fourbar").set(omega="3", g=Fraction(49, 5))
    assert model.get("omega") == 3
    assert model.get("g") == binary128.to_decimal(binary128.from_value("9.8"))
    run = holosym.simulate(model, M=4, h="1/32", T=1, every=16)
    header, rows = run_cli(holosym_exe, "--model", os.path.join(MODELS, "fourbar.hsm"),
                           "--set", "omega=3", "--set", "g=9.8", "--M", "4", "--h",
                           "1/32", "--T", "1", "--every", "16")
    q, p = run.exact(-1)
    assert [csv_real(x) for x in p] == fields_of(header, rows[-1], "p", model.n)
    assert [csv_real(x) for x in q] == fields_of(header, rows[-1], "q", model.n)


# ---------------------------------------------------------------- simulate and Run

def test_run_arrays_and_definitions():
    model = holosym.Model.builtin("pendulum")
    run = holosym.simulate(model, M=3, h="1/16", T=2, every=4)
    assert run.steps == 32 and len(run) == 9
    assert run.q.shape == run.p.shape == (9, 3)
    assert run.q.dtype == np.float64
    np.testing.assert_array_equal(run.t, np.arange(9) * 0.25)
    h0 = Fraction(run.exact_energy(0))
    for k in range(len(run)):
        expected = (Fraction(run.exact_energy(k)) - h0) / h0
        assert run.energy_error[k] == float(expected)
        q, _ = run.exact(k)
        assert run.q[k].tolist() == [float(x) for x in q]
        assert all(isinstance(x, Decimal) for x in q)
    assert 0 < np.max(np.abs(run.energy_error[1:])) < 1e-10
    assert run.h == Decimal("0.0625")
    # the last row is written even when `every` does not divide the steps
    assert len(holosym.simulate(model, M=2, h="1/16", steps=10, every=4)) == 4


def test_precision_other_than_quad_or_double_is_refused():
    with pytest.raises(holosym.Error) as caught:
        holosym.simulate(holosym.Model.builtin("pendulum"), M=2, h=0.1, T=1,
                         precision="single")
    assert caught.value.code == holosym.INVALID_ARGUMENT
    assert "'quad'" in caught.value.message and "'double'" in caught.value.message


# ---------------------------------------------------------------- models

def test_builtin_models_and_unknown_name():
    names = holosym.builtin_models()
    for name in ("pendulum", "spherical_pendulum", "planar_pendulum", "double_pendulum",
                 "spring_linkage", "magnetic_sphere", "sphere_dumbbell", "water",
                 "fourbar"):
        assert name in names
        model = holosym.Model.builtin(name)
        assert model.n > model.m >= 1
    with pytest.raises(holosym.Error) as caught:
        holosym.Model.builtin("nope")
    assert caught.value.code == holosym.INVALID_ARGUMENT
    assert "fourbar" in caught.value.message and "planar_pendulum" in caught.value.message


def test_model_names_and_parameters():
    model = holosym.Model.from_file(os.path.join(MODELS, "fourbar.hsm"))
    assert (model.n, model.m) == (4, 3)
    assert model.coordinate_names == ("xb", "yb", "xc", "yc")
    assert model.momentum_names[1] == "pyb"
    assert len(model.parameter_names) == 9 and "omega" in model.parameters
    q, p = model.initial_state()
    assert len(q) == len(p) == 4


def test_model_round_trip(tmp_path):
    model = holosym.Model.builtin("double_pendulum")
    path = tmp_path / "copy.hsm"
    model.save(path)
    again = holosym.Model.from_file(path)
    assert again.text == model.text
    assert again.parameters == model.parameters
    assert again.coordinate_names == model.coordinate_names
    assert again.initial_state() == model.initial_state()
    third = holosym.Model(again.text)
    a = holosym.simulate(model, M=3, h="1/20", steps=20, every=20)
    b = holosym.simulate(third, M=3, h="1/20", steps=20, every=20)
    assert a.exact(-1) == b.exact(-1)


def test_bad_model_text_gives_line_and_column(tmp_path):
    text = open(os.path.join(MODELS, "planar_pendulum.hsm")).read()
    broken = text + "\nhamiltonian = (x +\n"
    with pytest.raises(holosym.Error) as caught:
        holosym.Model(broken)
    assert caught.value.code == holosym.INVALID_MODEL
    assert re.match(r"model:\d+:\d+: ", caught.value.message), caught.value.message
    path = tmp_path / "broken.hsm"
    path.write_text(broken)
    with pytest.raises(holosym.Error) as caught:
        holosym.Model.from_file(path)
    assert re.match(re.escape(str(path)) + r":\d+:\d+: ", caught.value.message)
    with pytest.raises(holosym.Error) as caught:
        holosym.Model.from_file(tmp_path / "missing.hsm")
    assert caught.value.code == holosym.INVALID_ARGUMENT
    assert "missing.hsm" in caught.value.message
    with pytest.raises(holosym.Error) as caught:
        holosym.Model(b"bytes")
    assert caught.value.code == holosym.INVALID_ARGUMENT


def test_unknown_parameter_and_bad_values():
    model = holosym.Model.builtin("fourbar")
    before = model.parameters
    with pytest.raises(holosym.Error) as caught:
        model.set(nosuch=1)
    assert caught.value.code == holosym.INVALID_ARGUMENT
    assert "nosuch" in caught.value.message
    with pytest.raises(holosym.Error) as caught:
        model.set(g="inf")
    assert caught.value.code == holosym.INVALID_ARGUMENT
    with pytest.raises(holosym.Error) as caught:
        model.set(g="two")
    assert caught.value.code == holosym.INVALID_ARGUMENT and "parameter g" in \
        caught.value.message
    with pytest.raises(holosym.Error):
        model.get("nosuch")
    assert model.parameters == before


# ---------------------------------------------------------------- the Integrator

def test_integrator_steps_integrate_and_simulate_agree():
    model = holosym.Model.builtin("planar_pendulum")
    one = holosym.Integrator(model, M=4, h="1/16")
    for _ in range(20):
        one.step()
    two = holosym.Integrator(model, M=4)
    assert two.integrate(20, h=Fraction(1, 16)) == 20
    run = holosym.simulate(model, M=4, h=Decimal("0.0625"), steps=20, every=20)
    assert two.state == run.exact(-1)
    # step by step: the same states to round-off (integrate starts each Newton solve
    # from the step before)
    for a, b in zip(one.state[0] + one.state[1], two.state[0] + two.state[1]):
        assert abs(a - b) < Decimal("1e-31")
    assert one.t == two.t == Fraction(20, 16)
    q, p = one.state_float
    assert q.tolist() == [float(x) for x in one.state[0]]
    assert np.array_equal(one.q, q) and np.array_equal(one.p, p)


def test_set_state_exact_inputs_and_energy():
    model = holosym.Model.builtin("planar_pendulum")
    integ = holosym.Integrator(model, M=2, h="1/8")
    q0, p0 = model.initial_state()
    integ.set_state(q0, p0)
    assert integ.state == (q0, p0)
    integ.set_state([Fraction(3, 5), "-4/5"], [Decimal("0.8"), 0.6])
    q, p = integ.state
    assert q[0] == binary128.to_decimal(binary128.from_value("0.6"))
    assert p[1] == Decimal(0.6)  # a float is taken at its exact value
    assert abs(integ.constraint()[0]) < 1e-33
    integ.project()  # Phi H_p = 0.8 (0.6 - float(0.6)) != 0: onto the manifold
    h0 = integ.energy(exact=True)
    integ.integrate(16)
    assert 0 < abs((integ.energy(exact=True) - h0) / h0) < Decimal("1e-5")  # order 4, h = 1/8


def test_dense_output_and_observer():
    model = holosym.Model.builtin("planar_pendulum")
    integ = holosym.Integrator(model, M=4, h="1/16")
    with pytest.raises(holosym.Error) as caught:
        integ.dense_output(0.5)  # no step yet
    assert caught.value.code == holosym.NOT_INITIALIZED
    seen = []

    def observer(step, t, q, p):
        qd, _, lam = integ.dense_output(1)
        seen.append((step, t, q.copy(), qd, lam))
        return step == 3  # stop after step 3

    assert integ.integrate(10, observer=observer) == 3
    assert [s[0] for s in seen] == [1, 2, 3]
    assert [s[1] for s in seen] == [1 / 16, 2 / 16, 3 / 16]
    for _, _, q, qd, lam in seen:
        np.testing.assert_allclose(qd, q, rtol=0, atol=1e-25)
        assert lam.shape == (1,)
    assert integ.t == Fraction(3, 16)
    exact_seen = []
    integ.integrate(2, observer=lambda *args: exact_seen.append(args), exact=True)
    assert exact_seen[-1][1] == Decimal("0.3125")
    assert exact_seen[-1][2] == integ.state[0]
    q_mid, p_mid, _ = integ.dense_output("1/2", exact=True)
    assert all(isinstance(x, Decimal) for x in q_mid + p_mid)


def test_observer_exception_stops_the_run_and_is_raised():
    model = holosym.Model.builtin("planar_pendulum")
    integ = holosym.Integrator(model, M=3, h="1/16")
    reference = holosym.Integrator(model, M=3, h="1/16")
    reference.integrate(4)

    def observer(step, t, q, p):
        if step == 4:
            raise KeyError("stop here")

    with pytest.raises(KeyError, match="stop here"):
        integ.integrate(100, observer=observer)
    assert integ.state == reference.state  # the state of the last step seen
    assert integ.t == Fraction(4, 16)
    assert integ.integrate(2) == 2  # and the integrator goes on


def test_project_onto_the_manifold():
    model = holosym.Model.builtin("planar_pendulum")
    integ = holosym.Integrator(model, M=2, h="1/16")
    integ.set_state(["0.6", "-0.81"], ["0.8", "0.61"])
    assert abs(integ.constraint()[0]) > 1e-3
    integ.project()
    assert abs(integ.constraint(exact=True)[0]) < Decimal("1e-32")


def test_bad_step_sizes_keep_the_state():
    model = holosym.Model.builtin("planar_pendulum")
    integ = holosym.Integrator(model, M=2)
    before = integ.state
    for h, code in ((0, holosym.INVALID_STEP_SIZE), ("-1/16", holosym.INVALID_STEP_SIZE),
                    ("nan", holosym.INVALID_STEP_SIZE), ("inf", holosym.INVALID_STEP_SIZE),
                    ("x", holosym.INVALID_ARGUMENT),
                    (None, holosym.INVALID_STEP_SIZE)):
        with pytest.raises(holosym.Error) as caught:
            integ.step(h)
        assert caught.value.code == code, (h, caught.value)
        assert caught.value.message
        assert integ.state == before
    with pytest.raises(holosym.Error) as caught:
        integ.integrate(5, h=-0.5)
    assert caught.value.code == holosym.INVALID_STEP_SIZE and "h" in caught.value.message
    with pytest.raises(holosym.Error) as caught:
        integ.integrate(-1, h=0.5)
    assert caught.value.code == holosym.INVALID_STEP_COUNT
    assert integ.state == before
    with pytest.raises(holosym.Error) as caught:
        holosym.simulate(model, M=2, h=0, T=1)
    assert caught.value.code == holosym.INVALID_STEP_SIZE
    with pytest.raises(holosym.Error) as caught:
        holosym.simulate(model, M=2, h="1/16", T=1, every=0)
    assert caught.value.code == holosym.INVALID_ARGUMENT


def test_misuse_is_an_error_not_a_crash():
    model = holosym.Model.builtin("planar_pendulum")
    with pytest.raises(holosym.Error) as caught:
        holosym.Integrator(model, M=0)
    assert caught.value.code == holosym.INVALID_ORDER
    with pytest.raises(holosym.Error) as caught:
        holosym.Integrator(model, M=2, N=1, G=1)
    assert caught.value.code == holosym.INVALID_ORDER
    with pytest.raises(holosym.Error) as caught:
        holosym.Integrator(model, M="2")
    assert caught.value.code == holosym.INVALID_ORDER
    with pytest.raises(holosym.Error) as caught:
        holosym.Integrator("not a model")
    assert caught.value.code == holosym.INVALID_ARGUMENT
    integ = holosym.Integrator(model, M=2, h="1/16")
    with pytest.raises(holosym.Error) as caught:
        integ.set_state([1, 2, 3], [0, 0])
    assert caught.value.code == holosym.SIZE_MISMATCH
    with pytest.raises(holosym.Error) as caught:
        integ.set_state(["1", "zero"], [0, 0])
    assert caught.value.code == holosym.INVALID_ARGUMENT and "q[1]" in caught.value.message
    integ.close()
    for call in (integ.step, lambda: integ.integrate(1), integ.project, integ.energy,
                 lambda: integ.dense_output(0)):
        with pytest.raises(holosym.Error) as caught:
            call()
        assert caught.value.code == holosym.NOT_INITIALIZED
        assert "not a live integrator" in caught.value.message
    integ.close()  # twice: ignored


def test_error_carries_code_and_message():
    error = holosym.Error(holosym.INVALID_STEP_SIZE, "h must be > 0")
    assert error.code == -4 and error.message == "h must be > 0"
    assert "HOLOSYM_INVALID_STEP_SIZE" in str(error)


# ---------------------------------------------------------------- ensembles

def test_ensemble_matches_single_runs():
    model = holosym.Model.builtin("planar_pendulum")
    states = [(["0.6", "-0.8"], ["0.8", "0.6"]), ([0, -1], ["1/2", 0]),
              ([1, 0], [0, "0.1"])]
    result = holosym.ensemble(model, states, M=3, h="1/16", T=1)
    assert result.q.shape == result.p.shape == (3, 2)
    assert result.status.tolist() == [0, 0, 0]
    for i, (q, p) in enumerate(states):
        single = holosym.Integrator(model, M=3, h="1/16", q=q, p=p)
        single.integrate(16)
        assert result.exact(i) == single.state
        assert result.q[i].tolist() == single.q.tolist()
        end = Fraction(single.energy(exact=True))
        start = holosym.Integrator(model, M=3, q=q, p=p).energy(exact=True)
        assert result.energy_error[i] == float((end - Fraction(start)) / Fraction(start))
    assert np.all(np.abs(result.energy_error) < 1e-8)
    assert np.all(result.constraint_residual < 1e-30)


def test_ensemble_errors_raise_or_are_recorded():
    model = holosym.Model.builtin("planar_pendulum")
    states = [([0, -1], ["1/2", 0]), ([0, -1, 5], [0, 0]), ([1, 0], [0, "0.1"])]
    with pytest.raises(holosym.Error) as caught:
        holosym.ensemble(model, states, M=2, h="1/16", steps=4)
    assert caught.value.code == holosym.SIZE_MISMATCH
    assert "member 1" in caught.value.message
    result = holosym.ensemble(model, states, M=2, h="1/16", steps=4, errors="record")
    assert result.status.tolist() == [0, holosym.SIZE_MISMATCH, 0]
    assert np.all(np.isnan(result.q[1])) and np.all(np.isfinite(result.q[[0, 2]]))
    assert "3 values" not in result.messages[0] and "2 values" in result.messages[1]
    with pytest.raises(holosym.Error):
        result.exact(1)


def test_status_codes_follow_the_header():
    """The package's status codes are those of include/holosym.h (the header is itself
    tested against the library's table by the Fortran suite): every HOLOSYM_ code there
    with its value, and no other."""
    import re
    from conftest import REPO
    with open(os.path.join(REPO, "include", "holosym.h"), encoding="utf-8") as header:
        defined = {name: int(value) for name, value in re.findall(
            r"^#define HOLOSYM_([A-Z_]+) \(?(-?\d+)\)?", header.read(), re.M)
            if not name.startswith("NAME_")}
    ours = {name: getattr(holosym, name) for name in dir(holosym)
            if name.isupper() and isinstance(getattr(holosym, name), int)}
    assert ours == defined


def test_plan_accuracy_reaches_the_request():
    # holosym chooses (M, N, G) and h for 1e-20 at T = 10; the run reaches T and the
    # error against 1280 steps of order 16 is within 10 times the request
    model = holosym.Model.builtin("spherical_pendulum")
    planned = holosym.Integrator(model)
    steps = planned.plan_accuracy(Decimal("1e-20"), 10)
    assert planned.orders == (8, 7, 9)
    assert planned.integrate(steps) == steps
    assert abs(float(planned.t) - 10) < 1e-12
    reference = holosym.Integrator(model, M=8, h=Fraction(10, 1280))
    assert reference.integrate(1280) == 1280
    error = max(abs(a - b) for a, b in zip(planned.state[0] + planned.state[1],
                                           reference.state[0] + reference.state[1]))
    assert error <= Decimal("1e-19")
    with pytest.raises(holosym.Error) as failure:
        planned.plan_accuracy(2, 10)
    assert failure.value.code == holosym.INVALID_ARGUMENT
    assert "tolerance" in str(failure.value)


# The planar pendulum released at rest at 1 rad passes the vertical at t = (2j + 1) K,
# K = K(sin(1/2)) (40 digits from mpmath's ellipk(sin(1/2)^2)).
QUARTER = Decimal("1.674993916092613178175302844790253856807")


def passage(j):
    """The time of passage j (from 0), (2j + 1) K, to 60 digits."""
    import decimal
    with decimal.localcontext() as context:
        context.prec = 60
        return (2 * j + 1) * QUARTER


def distance(a, b):
    """|a - b| of Decimals or Fractions, to 60 digits (the default context rounds to 28)."""
    import decimal
    with decimal.localcontext() as context:
        context.prec = 60
        if isinstance(b, Fraction):
            b = Decimal(b.numerator) / b.denominator
        return abs(a - b)


def test_events_at_the_exact_passages():
    # g = x with every digit (exact=True): the passages within the scheme's accuracy at
    # (8, 7, 9), h = 1/16, falling then rising; with floats g limits them to about 1e-16
    model = holosym.Model.builtin("planar_pendulum")
    integ = holosym.Integrator(model, M=8, h=Fraction(1, 16))
    found, stopped = integ.integrate_events(96, [lambda t, q, p: q[0]], exact=True)
    assert not stopped and len(found) == 2
    assert [e.direction for e in found] == [-1, 1]
    for j, event in enumerate(found):
        assert distance(event.t, passage(j)) < Decimal("1e-29")
        assert abs(event.q[0]) < Decimal("1e-29")
        assert event.index == 0 and len(event.lam) == 1
    assert integ.t == 6
    floats = holosym.Integrator(model, M=8, h=Fraction(1, 16))
    found, _ = floats.integrate_events(96, [lambda t, q, p: q[0]])
    assert len(found) == 2 and abs(found[0].t - float(QUARTER)) < 1e-12


def test_terminal_event_ends_the_run_there():
    # a terminal rising passage: the run stops at 3K with the state there; a second
    # function t - 1 (any direction) is reported before it
    model = holosym.Model.builtin("planar_pendulum")
    integ = holosym.Integrator(model, M=8, h=Fraction(1, 16))
    found, stopped = integ.integrate_events(
        200, [lambda t, q, p: q[0], lambda t, q, p: t - 1], directions=[1, 0],
        terminal=[True, False], exact=True)
    assert stopped and [e.index for e in found] == [1, 0]
    assert distance(found[0].t, Decimal(1)) < Decimal("1e-30")
    assert distance(found[1].t, passage(1)) < Decimal("1e-29")
    assert integ.state[0] == found[1].q and integ.state[1] == found[1].p
    assert distance(found[1].t, integ.t) < Decimal("1e-40")


def test_events_bad_input():
    model = holosym.Model.builtin("planar_pendulum")
    integ = holosym.Integrator(model, M=4, h=Fraction(1, 8))
    start = integ.state
    with pytest.raises(holosym.Error) as failure:
        integ.integrate_events(8, [])
    assert failure.value.code == holosym.INVALID_ARGUMENT
    with pytest.raises(holosym.Error) as failure:
        integ.integrate_events(8, [lambda t, q, p: q[0]], directions=[2])
    assert failure.value.code == holosym.INVALID_ARGUMENT
    with pytest.raises(holosym.Error) as failure:
        integ.integrate_events(8, [lambda t, q, p: q[0]], directions=[1, 0])
    assert failure.value.code == holosym.SIZE_MISMATCH
    assert integ.state == start

    def broken(t, q, p):
        if t > 0.5:
            raise ZeroDivisionError("broken event function")
        return q[0]

    with pytest.raises(ZeroDivisionError):
        integ.integrate_events(8, [broken])
    assert integ.t == Fraction(5, 8)  # the steps before the failure stand
