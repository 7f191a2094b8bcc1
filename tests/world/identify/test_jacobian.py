"""Secant Jacobians of the joint fit: forward differences, Broyden updates, and a solve with fewer evaluations."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import least_squares

from world.identify.jacobian import SecantJacobian, broyden_update, forward_difference


def _residuals(x: np.ndarray) -> np.ndarray:
    """A small nonlinear least-squares problem (m = 4, n = 3) with its zero at (1, -2, 0.5)."""
    a, b, c = x
    return np.array([a - 1.0, 10.0 * (b + 2.0 - (a - 1.0) ** 2), np.exp(c) - np.exp(0.5), a * b * c + 1.0])


def _analytic(x: np.ndarray) -> np.ndarray:
    a, b, c = x
    return np.array([
        [1.0, 0.0, 0.0],
        [-20.0 * (a - 1.0), 10.0, 0.0],
        [0.0, 0.0, np.exp(c)],
        [b * c, a * c, a * b],
    ])


def test_forward_difference_matches_the_analytic_jacobian_and_respects_the_upper_bound():
    x = np.array([0.3, -1.2, 0.8])
    high = np.array([np.inf, np.inf, 0.8])  # c sits on its upper bound: its step must go down
    probes = []

    def recorded(z):
        probes.append(z.copy())
        return _residuals(z)

    jacobian = forward_difference(recorded, x, _residuals(x), high)
    np.testing.assert_allclose(jacobian, _analytic(x), rtol=1e-5, atol=1e-5)
    assert len(probes) == 3 and all(p[2] <= 0.8 for p in probes)


def test_broyden_update_satisfies_the_secant_equation_with_the_least_change():
    rng = np.random.default_rng(3)
    jacobian, dx, df = rng.normal(size=(4, 3)), rng.normal(size=3), rng.normal(size=4)
    updated = broyden_update(jacobian, dx, df)
    np.testing.assert_allclose(updated @ dx, df)
    # Directions orthogonal to the step are untouched.
    orthogonal = np.cross(dx, rng.normal(size=3))
    np.testing.assert_allclose(updated @ orthogonal, jacobian @ orthogonal)
    assert broyden_update(jacobian, np.zeros(3), df) is jacobian


def test_secant_solve_reaches_the_same_minimum_with_fewer_evaluations():
    x0 = np.array([0.0, 0.0, 0.0])
    bounds = (np.full(3, -5.0), np.full(3, 5.0))
    calls = {"secant": 0, "forward": 0}

    def counted(kind):
        def fn(x):
            calls[kind] += 1
            return _residuals(x)
        return fn

    forward = least_squares(counted("forward"), x0, bounds=bounds, method="trf", xtol=1e-12, ftol=1e-12, gtol=1e-12)
    secant = SecantJacobian(counted("secant"), bounds[1], stall=1e-12)
    result = least_squares(secant.fun, x0, jac=secant, bounds=bounds, method="trf", xtol=1e-12, ftol=1e-12, gtol=1e-12)
    np.testing.assert_allclose(result.x, forward.x, atol=1e-5)
    np.testing.assert_allclose(result.x, [1.0, -2.0, 0.5], atol=1e-5)
    assert calls["secant"] < calls["forward"]


def test_a_stall_with_a_fresh_jacobian_is_reported():
    flat = SecantJacobian(lambda x: np.array([1.0, 2.0]), np.full(2, np.inf), stall=0.01)
    flat(np.zeros(2))  # first call: forward difference
    assert flat.fresh and not flat.stalled
    flat(np.ones(2))  # no decrease after a step from a fresh Jacobian
    assert flat.stalled


@pytest.mark.parametrize("stall", [0.0, 0.5])
def test_a_slow_step_from_an_updated_jacobian_refreshes_it(stall):
    values = iter([np.array([4.0]), np.array([4.0]), np.array([2.0]), np.array([1.9]), np.array([1.9])])
    secant = SecantJacobian(lambda x: next(values), np.full(1, np.inf), stall=stall)
    secant(np.zeros(1))  # fresh: evaluates x and x + h
    secant(np.ones(1))  # cost 16 -> 4: a good step, Broyden update
    assert not secant.fresh
    secant(np.full(1, 2.0))  # cost 4 -> 3.61: 10 % lower; slow only for stall 0.5 -> fresh forward difference
    assert secant.fresh == (stall == 0.5)
