"""The tangent map of a step and the Lyapunov spectrum through Python: the tangent map
against central differences of the step map on the manifold, the symplectic form it
keeps, the spectrum's pairs on a chaotic double pendulum, and bad input (codes, state
unchanged)."""

from decimal import Decimal, localcontext
from fractions import Fraction
import os

import numpy as np
import pytest

import holosym
from conftest import MODELS

# (precision, difference step, agreement of the tangent map with the differences, of
# the symplectic form after 20 steps with its start)
PRECISIONS = [("quad", Decimal("1e-9"), 1e-15, 1e-28), ("double", Decimal("1e-5"), 1e-7, 1e-12)]


def stepped(model, q, p, h, precision):
    """The state after one step of size h from (q, p) projected onto the manifold."""
    integ = holosym.Integrator(model, M=4, h=h, precision=precision)
    integ.set_state(q, p)
    integ.project()
    integ.step()
    q1, p1 = integ.state
    return np.array(q1 + p1, dtype=object)


@pytest.mark.parametrize("precision, eps, agreement, _", PRECISIONS)
def test_tangent_map_is_the_derivative_of_the_step(precision, eps, agreement, _):
    model = holosym.Model.builtin("spherical_pendulum")
    integ = holosym.Integrator(model, M=4, h="1/8", precision=precision)
    q, p = integ.state
    dq, dp = integ.tangent_basis(exact=True)
    images_q, images_p = integ.step_tangent(dq, dp, exact=True)
    assert len(images_q) == 4 and len(images_q[0]) == 3
    assert integ.tangent_basis()[0].shape == (4, 3)
    for j in range(4):
        with localcontext() as context:
            context.prec = 60
            plus = [x + eps * v for x, v in zip(q + p, dq[j] + dp[j])]
            minus = [x - eps * v for x, v in zip(q + p, dq[j] + dp[j])]
            difference = (stepped(model, plus[:3], plus[3:], "1/8", precision)
                          - stepped(model, minus[:3], minus[3:], "1/8", precision)) / (2 * eps)
            image = images_q[j] + images_p[j]
            deviation = max(abs(a - b) for a, b in zip(image, difference))
            assert deviation <= Decimal(agreement) * max(abs(a) for a in image), (j, deviation)


@pytest.mark.parametrize("precision, _, __, agreement", PRECISIONS)
def test_tangent_map_keeps_the_symplectic_form(precision, _, __, agreement):
    integ = holosym.Integrator(holosym.Model.builtin("spherical_pendulum"), M=4, h="1/8",
                               precision=precision)
    dq, dp = integ.tangent_basis(exact=True)

    def form(vq, vp):
        vq = np.array(vq, dtype=object)
        vp = np.array(vp, dtype=object)
        with localcontext() as context:
            context.prec = 80
            return np.array(vq.dot(vp.T) - vp.dot(vq.T), dtype=float)

    start = form(dq, dp)
    assert np.max(np.abs(start)) > 0.1
    for _step in range(20):
        dq, dp = integ.step_tangent(dq, dp, exact=True)
    assert integ.t == Fraction(20, 8)
    assert np.max(np.abs(form(dq, dp) - start)) <= agreement * np.max(np.abs(start))


def test_lyapunov_spectrum_of_a_chaotic_double_pendulum():
    model = holosym.Model.from_file(os.path.join(MODELS, "double_pendulum.hsm"))
    model.set(m2=1, l2=1, theta1=2, theta2="2.5")
    runs = []
    for k in (1, 2):
        integ = holosym.Integrator(model, M=4, h=f"1/{16 * k}")
        exponents, megno = integ.lyapunov(400 * k)
        assert integ.t == 25
        assert exponents.shape == (4,) and list(exponents) == sorted(exponents, reverse=True)
        assert exponents[0] > 0.3 and 25 * abs(exponents[0] + exponents[3]) <= 2
        assert 25 * max(abs(exponents[1]), abs(exponents[2])) <= 3
        assert megno > 4
        runs.append(exponents[0])
    assert abs(runs[0] - runs[1]) <= 1e-3 * runs[1]


def test_tangent_bad_input_keeps_the_state():
    integ = holosym.Integrator(holosym.Model.builtin("spherical_pendulum"), M=4, h="1/8")
    before = integ.state
    q, _ = integ.state
    with pytest.raises(holosym.Error) as caught:          # radial: off the tangent space
        integ.step_tangent([q], [[0, 0, 0]])
    assert caught.value.code == holosym.OFF_MANIFOLD and "step_tangent" in caught.value.message
    assert integ.state == before and integ.t == 0
    dq, dp = integ.project_tangent([q], [[0, 0, 0]])
    assert np.max(np.abs(dq)) < 1e-25                     # the radial part is all there was
    for bad_q, bad_p in (([[1, 0]], [[0, 0]]), ([[1, 0, 0]], [[0, 0, 0], [0, 0, 0]]),
                         (np.zeros((0, 3)), np.zeros((0, 3)))):
        with pytest.raises(holosym.Error) as caught:
            integ.step_tangent(bad_q, bad_p)
        assert caught.value.code == holosym.SIZE_MISMATCH
    with pytest.raises(holosym.Error) as caught:
        integ.step_tangent([["x", 0, 0]], [[0, 0, 0]])
    assert caught.value.code == holosym.INVALID_ARGUMENT
    with pytest.raises(holosym.Error) as caught:
        integ.lyapunov(-1)
    assert caught.value.code == holosym.INVALID_STEP_COUNT
    assert integ.state == before and integ.t == 0
