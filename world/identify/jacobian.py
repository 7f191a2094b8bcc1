"""Jacobians of the joint fit's residuals at the cost of a few rollouts per iteration.

A forward-difference Jacobian costs one rollout per free parameter, and it
was ~95 % of the rollouts of the joint refinement (docs/benchmarks.md). The
``SecantJacobian`` computes it by forward differences at the start of a
stage and then updates it with Broyden's rank-one secant formula from each
accepted step (no rollout); when a step taken with an updated Jacobian
lowers the cost by less than the stall share, the next Jacobian is a fresh
forward difference again, and a stall with a fresh one ends the stage.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

# scipy's '2-point' relative step: sqrt of the double-precision epsilon.
FORWARD_STEP = float(np.sqrt(np.finfo(float).eps))


def forward_difference(
    residuals: Callable[[np.ndarray], np.ndarray], x: np.ndarray, f: np.ndarray, high: np.ndarray
) -> np.ndarray:
    """(m, n) forward-difference Jacobian of ``residuals`` at x (n,), with f = residuals(x) (m,).

    Steps are FORWARD_STEP * max(1, |x_j|), taken downwards when the upper bound ``high`` (n,) is closer.
    """
    jacobian = np.empty((f.size, x.size))
    for j in range(x.size):
        step = FORWARD_STEP * max(1.0, abs(float(x[j])))
        if x[j] + step > high[j]:
            step = -step
        probe = x.copy()
        probe[j] += step
        jacobian[:, j] = (residuals(probe) - f) / (probe[j] - x[j])
    return jacobian


def broyden_update(jacobian: np.ndarray, dx: np.ndarray, df: np.ndarray) -> np.ndarray:
    """Broyden's rank-one update: the least change to ``jacobian`` (m, n) with J dx = df."""
    norm = float(dx @ dx)
    if norm == 0.0:
        return jacobian
    return jacobian + np.outer(df - jacobian @ dx, dx) / norm


class SecantJacobian:
    """``jac`` for scipy's least_squares, with ``residuals`` wrapped by ``fun`` (it remembers the last value).

    stall: relative cost decrease below which a step counts as stalled.
    ``stalled`` is True once a step computed from a fresh forward-difference
    Jacobian stalled (the caller's callback ends the stage then).
    """

    def __init__(self, residuals: Callable[[np.ndarray], np.ndarray], high: np.ndarray, stall: float) -> None:
        self._residuals = residuals
        self._high = high
        self._stall = stall
        self._last: tuple[np.ndarray, np.ndarray] | None = None  # the last point evaluated and its residuals
        self._previous: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None  # x, f, J at the last jac call
        self._fresh = False
        self.stalled = False

    @property
    def fresh(self) -> bool:
        """Whether the last Jacobian handed out was a forward difference (not a secant update)."""
        return self._fresh

    def fun(self, x: np.ndarray) -> np.ndarray:
        f = self._residuals(x)
        self._last = (x.copy(), f)
        return f

    def __call__(self, x: np.ndarray, *_: object) -> np.ndarray:
        if self._last is not None and np.array_equal(self._last[0], x):
            f = self._last[1]
        else:
            f = self.fun(x)
        if self._previous is None:
            jacobian = self._refresh(x, f)
        else:
            x0, f0, j0 = self._previous
            cost0, cost1 = float(f0 @ f0), float(f @ f)
            slow = cost0 - cost1 < self._stall * cost0
            if slow and self._fresh:
                self.stalled = True
            if slow and not self._fresh:
                jacobian = self._refresh(x, f)
            else:
                jacobian = broyden_update(j0, x - x0, f - f0)
                self._fresh = False
        self._previous = (x.copy(), f, jacobian)
        return jacobian

    def _refresh(self, x: np.ndarray, f: np.ndarray) -> np.ndarray:
        self._fresh = True
        jacobian = forward_difference(self._residuals, x, f, self._high)
        return jacobian
