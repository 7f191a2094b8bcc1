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
# A shorter stretch (or one that lost too small a share of its speed) still
# reads its friction when the fit pins it down: the standard error of log mu
# (from the fit's own residuals, so it scales with the track's noise) at most
# this, over at least FRICTION_READ_MIN_DOF residual degrees of freedom. Exact
# tracks read mu from five samples at 2.4 m/s to 1 %; six samples with a
# centimetre of noise do not pass (tests/world/identify/test_late_entry_mujoco.py).
FRICTION_READ_SIGMA = 0.1
FRICTION_READ_MIN_DOF = 3
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
    if t.shape[0] == 2:
        # Two samples fix a position and a velocity, not a friction too: any friction fits them exactly (the
        # optimiser's pick, up to the bound, set the velocity); the mean velocity between them is off the
        # start's by mu g dt / 2 (1.6 cm/s at mu 0.08, 25 fps).
        return SlideFit(start_time, p[0].copy(), velocity0, friction_prior, False, 0.0, 2)

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
    identified = identified or _log_friction_error(best, mu) <= FRICTION_READ_SIGMA
    plain = (slide_positions(t, start_time, position, velocity, mu, gravity) - p) * w[:, None]
    rmse = float(np.sqrt(np.sum(plain**2) / max(np.sum(w**2), 1e-12)))
    # A moving model must explain clearly more than standing still does.
    if rest_rmse < 1.5 * rmse:
        return rest
    return SlideFit(start_time, position, velocity, mu, identified, rmse, int(t.shape[0]))


def _log_friction_error(result, mu: float) -> float:
    """Standard error of log mu of a slide fit (scipy ``least_squares`` result over the parameters position,
    velocity, log mu): the Gauss-Newton covariance scaled by the residual variance; inf when mu is at a bound,
    the residuals leave fewer than FRICTION_READ_MIN_DOF degrees of freedom or the Jacobian is singular."""
    jacobian = np.asarray(result.jac, dtype=float)
    dof = jacobian.shape[0] - jacobian.shape[1]
    if dof < FRICTION_READ_MIN_DOF or not MU_BOUNDS[0] * 1.01 < mu < MU_BOUNDS[1] * 0.99:
        return np.inf
    variance = float(result.fun @ result.fun) / dof
    try:
        covariance = np.linalg.inv(jacobian.T @ jacobian) * variance
    except np.linalg.LinAlgError:
        return np.inf
    return float(np.sqrt(max(covariance[4, 4], 0.0)))


# A tail of a stretch whose samples all miss the slide of the samples before
# the last LATE_DEPARTURE_WINDOW by more than this many robust standard
# deviations of that slide's own misses (and at least LATE_DEPARTURE_FLOOR)
# left it: a collision in the last frames of the video, which the change-point
# analysis (6 frames after a contact) cannot see yet.
LATE_DEPARTURE_SIGMAS = 4.0
LATE_DEPARTURE_FLOOR = 0.01  # m
LATE_DEPARTURE_WINDOW = 12  # last samples where a departure is looked for
LATE_DEPARTURE_MIN_SAMPLES = 3  # departed samples needed to read the new velocity
LATE_DEPARTURE_MIN_BEFORE = 5  # samples before the window that give the slide


def late_departure(times: np.ndarray, positions: np.ndarray, stretch: SlideFit, gravity: float) -> int | None:
    """Index of the first sample of the stretch's tail that left its slide, or None.

    times: (T,) s, increasing, the stretch's samples up to the last observed
    frame; positions: (T, 2) m; stretch: the slide fitted to them (cheap
    rejection: its last sample within LATE_DEPARTURE_FLOOR). The slide of
    the samples before the last LATE_DEPARTURE_WINDOW is refitted (the whole
    stretch's fit bends towards the tail); the tail is the longest run of last
    samples that each miss it by more than the threshold; at least
    LATE_DEPARTURE_MIN_SAMPLES of them, after its first (the contact's own
    frame, blurred by the contact), are needed.
    """
    times = np.asarray(times, dtype=np.float64)
    positions = np.asarray(positions, dtype=np.float64)[:, :2]
    last_miss = slide_positions(times[-1:], stretch.start_time, stretch.position, stretch.velocity, stretch.friction, gravity)[0] - positions[-1]
    head = times.size - LATE_DEPARTURE_WINDOW
    if float(np.hypot(*last_miss)) <= LATE_DEPARTURE_FLOOR or head < LATE_DEPARTURE_MIN_BEFORE:
        return None
    base = fit_slide(times[:head], positions[:head], np.ones(head), gravity, stretch.friction)
    miss = np.linalg.norm(slide_positions(times, base.start_time, base.position, base.velocity, base.friction, gravity) - positions, axis=1)
    threshold = max(LATE_DEPARTURE_FLOOR, LATE_DEPARTURE_SIGMAS * 1.4826 * float(np.median(miss[:head])))
    tail = 0
    while tail < LATE_DEPARTURE_WINDOW and miss[miss.size - 1 - tail] > threshold:
        tail += 1
    if tail < LATE_DEPARTURE_MIN_SAMPLES + 1:
        return None
    return miss.size - tail + 1  # drop the contact's own frame


def tail_state(times: np.ndarray, positions: np.ndarray, friction: float, gravity: float, at: float) -> tuple[np.ndarray, np.ndarray]:
    """Position (2,) m and velocity (2,) m/s at time ``at`` (s) from a short tail of samples.

    times: (T,) s, T >= 2; positions: (T, 2) m. A slide at the known
    deceleration ``friction * gravity``: a straight line in time gives the
    direction, the deceleration is added back along it and a second line
    gives the position and velocity at the tail's mid-time, slid on to ``at``.
    """
    times = np.asarray(times, dtype=np.float64)
    positions = np.asarray(positions, dtype=np.float64)[:, :2]
    mid = float(times.mean())
    offsets = times - mid
    slope, _ = np.polyfit(offsets, positions, 1)
    speed = float(np.hypot(*slope))
    if speed == 0.0:
        return positions.mean(axis=0), np.zeros(2)
    deceleration = friction * gravity
    direction = slope / speed
    slope, intercept = np.polyfit(offsets, positions + 0.5 * deceleration * offsets[:, None] ** 2 * direction, 1)
    speed = float(np.hypot(*slope))
    if speed == 0.0:
        return intercept, np.zeros(2)
    direction = slope / speed
    ahead = at - mid
    if deceleration > 0.0:
        ahead = min(ahead, speed / deceleration)
    return (intercept + direction * (speed * ahead - 0.5 * deceleration * ahead * ahead),
            direction * (speed - deceleration * ahead))
