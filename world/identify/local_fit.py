"""Local closed-form fits: one body, one collision-free stretch of its track.

Supported sliding under Coulomb friction (DESIGN.md):
``s(tau) = |v0| tau - mu g tau^2 / 2`` along the initial direction, clamped
at the exact stopping time ``|v0| / (mu g)``. These fits initialise the
joint identification and, on their own, give the re-anchoring state at the
end of the observed window.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

MU_BOUNDS = (1e-5, 1.0)  # paper, Appendix A: 1e-5 < mu < 1
# A stretch whose positions stay within this RMS distance (metres) of their
# mean is at rest: about the tracking noise of a few millimetres.
REST_RMSE = 0.004
# Friction needs a deceleration seen over a real stretch: 8 frames at 25 fps
# (0.3 s) slow a body at mu = 0.05 by only 0.15 m/s.
MIN_FRICTION_SAMPLES = 8
# Weighted position residuals (m) beyond this count linearly, not squared
# (Huber): a perceived track has a few frames tens of centimetres off (a
# merged segment, a misread shape at the border) that must not drag a fit
# made from many good frames; exact tracks (residuals of millimetres) are
# fitted as with plain least squares.
ROBUST_SCALE = 0.03


def robust_residuals(residuals: np.ndarray, scale: float = ROBUST_SCALE) -> np.ndarray:
    """Residuals (any shape, m) whose squares sum to twice the Huber loss of the input.

    Unchanged within ``scale``; beyond it sign(r) sqrt(2 scale |r| - scale^2),
    so any least-squares solver (and its Jacobian) minimises the Huber loss
    without knowing it.
    """
    size = np.abs(residuals)
    return np.where(size <= scale, residuals, np.sign(residuals) * np.sqrt(np.maximum(2.0 * scale * size - scale**2, 0.0)))


@dataclass(frozen=True)
class SlideFit:
    """Result of fitting one sliding stretch.

    start_time: seconds of the first sample; position: (2,) metres at
    start_time; velocity: (2,) m/s at start_time; friction: mu (meaningful
    only when ``friction_identified``); rmse: metres over the samples.
    """

    start_time: float
    position: np.ndarray
    velocity: np.ndarray
    friction: float
    friction_identified: bool
    rmse: float
    samples: int

    def state_at(self, time: float, gravity: float) -> tuple[np.ndarray, np.ndarray]:
        """Position (2,) m and velocity (2,) m/s of the fitted slide at ``time`` (s)."""
        position = slide_positions(np.array([time]), self.start_time, self.position, self.velocity, self.friction, gravity)[0]
        speed = float(np.hypot(*self.velocity))
        if speed == 0.0:
            return position, np.zeros(2)
        remaining = max(speed - self.friction * gravity * (time - self.start_time), 0.0)
        return position, self.velocity / speed * remaining


def slide_positions(
    times: np.ndarray, start_time: float, position: np.ndarray, velocity: np.ndarray, friction: float, gravity: float
) -> np.ndarray:
    """Closed-form supported sliding.

    times: (T,) seconds (>= start_time). position, velocity: (2,) at start.
    Returns (T, 2) metres.
    """
    speed = float(np.hypot(*velocity))
    if speed == 0.0:
        return np.broadcast_to(position, (times.shape[0], 2)).copy()
    direction = velocity / speed
    deceleration = friction * gravity
    tau = np.clip(times - start_time, 0.0, speed / deceleration)
    travelled = speed * tau - 0.5 * deceleration * tau**2
    return position[None, :] + travelled[:, None] * direction[None, :]


def fit_slide(
    times: np.ndarray,
    positions: np.ndarray,
    weights: np.ndarray,
    gravity: float,
    friction_prior: float,
) -> SlideFit:
    """Fit start position, start velocity and friction to one stretch.

    times: (T,) seconds, increasing. positions: (T, 2) metres on the plane.
    weights: (T,) confidence in [0, 1]. friction_prior: mu for stretches at
    rest and a starting guess otherwise. ``friction_identified`` is False
    when the stretch shows too little deceleration to pin mu down (the
    fitted value is still returned). The first sample's time is the start
    time.
    """
    times = np.asarray(times, dtype=np.float64)
    positions = np.asarray(positions, dtype=np.float64)
    weights = np.asarray(weights, dtype=np.float64)
    keep = weights > 0
    if keep.sum() == 0:
        raise ValueError("fit_slide: no sample has a positive weight")
    t, p, w = times[keep], positions[keep], np.sqrt(weights[keep])
    start_time = float(times[0])
    if t.shape[0] == 1:
        return SlideFit(start_time, p[0].copy(), np.zeros(2), friction_prior, False, 0.0, 1)

    # Initial guess: straight line through the first and last samples.
    duration = max(t[-1] - t[0], 1e-9)
    velocity0 = (p[-1] - p[0]) / duration
    speed0 = float(np.hypot(*velocity0))
    centre = np.average(p, axis=0, weights=w**2)
    rest_rmse = float(np.sqrt(np.average(np.sum((p - centre) ** 2, axis=1), weights=w**2)))
    rest = SlideFit(start_time, centre, np.zeros(2), friction_prior, False, rest_rmse, int(t.shape[0]))
    if rest_rmse < REST_RMSE:
        return rest

    def residuals(params: np.ndarray) -> np.ndarray:
        position, velocity, log_mu = params[:2], params[2:4], params[4]
        predicted = slide_positions(t, start_time, position, velocity, float(np.exp(log_mu)), gravity)
        return robust_residuals(((predicted - p) * w[:, None]).ravel())

    best = None
    # Two starts: the prior friction, and a guess that would stop the body
    # right at the stretch's end (covers both coasting and stopping stretches).
    for mu_guess in (friction_prior, max(max(speed0, 0.05) * 2.0 / (gravity * duration), MU_BOUNDS[0] * 10)):
        mu_guess = float(np.clip(mu_guess, MU_BOUNDS[0] * 1.01, MU_BOUNDS[1] * 0.99))
        start = np.array([*p[0], *(velocity0 * 1.2), np.log(mu_guess)])
        result = least_squares(
            residuals,
            start,
            bounds=([-np.inf, -np.inf, -np.inf, -np.inf, np.log(MU_BOUNDS[0])], [np.inf, np.inf, np.inf, np.inf, np.log(MU_BOUNDS[1])]),
            x_scale=np.array([0.1, 0.1, 0.5, 0.5, 1.0]),
            max_nfev=200,
        )
        if best is None or result.cost < best.cost:
            best = result
    position, velocity, mu = best.x[:2], best.x[2:4], float(np.exp(best.x[4]))
    speed = float(np.hypot(*velocity))
    stop_time = speed / (mu * gravity) if speed > 0 else 0.0
    # Friction shows in the data only if the stretch saw a real fraction of the
    # deceleration (it stopped inside, or slowed down by a noticeable share).
    identified = t.shape[0] >= MIN_FRICTION_SAMPLES and (
        stop_time <= duration * 1.05 or (mu * gravity * duration) > 0.1 * speed
    )
    plain = (slide_positions(t, start_time, position, velocity, mu, gravity) - p) * w[:, None]
    rmse = float(np.sqrt(np.sum(plain**2) / max(np.sum(w**2), 1e-12)))
    # A moving model must explain clearly more than standing still does.
    if rest_rmse < 1.5 * rmse:
        return rest
    return SlideFit(start_time, position, velocity, mu, identified, rmse, int(t.shape[0]))
