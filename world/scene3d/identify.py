"""Closed-form identification of latent properties from 3D tracks, carried across curtains.

* friction (per body): a run of frames sliding on one supporting face is fitted
  with s(t) = s0 + v t + a t^2 / 2 along the direction of motion; then
  mu = (g_t . d - a) / (g n_z) (g_t the in-plane gravity, d the direction).
* restitution (per body): two ballistic arcs (p0 + v0 t - g t^2 z / 2, least
  squares with g known) around a contact with a static face are extrapolated
  to the plane at contact distance; e = -v_out.n / v_in.n. The tangential
  change gives the surface friction of the impact, mu = |dv_t| / ((1 + e)|v_in.n|); the time between
  the two arcs' plane crossings is the impact's duration (soft contacts hold the body for a while).
* mass ratio and pair restitution (per body pair): velocities just before and
  after a body-body contact from polynomial fits; momentum along the normal
  gives m_j / m_i = -dv_i.n / dv_j.n, and e = -(v_j' - v_i').n / (v_j - v_i).n.

Uncertainties are one standard deviation from the fits' residuals (delta
method); several measurements of one property combine by inverse variance
plus the spread between them (a random-effects mean, ``_combine``).
Array shapes: times (T,), positions (T, 3); units m, s, kg.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from world.scene3d.motion import contact_normal, face_coordinates, gap_between, quadratic_roots
from world.scene3d.types import Anchor3D, Body3D, Face, FittedProperty, Phase3D, State3D, Tracks3D, World3D

TOUCH_DISTANCE = 0.012  # m: a centre this close to its contact distance from a face is touching it
MOVING_SPEED = 0.05  # m/s: slower counts as at rest for friction fits
MIN_SLIDE_FRAMES = 5
MIN_ARC_FRAMES = 2  # a ballistic arc with g known is fixed by two frames
EDGE_FRAMES = 2  # frames dropped at each end of a sliding run (landing, ramp kink, soft-contact settling)
POSITION_NOISE_FLOOR = 1e-4  # m: annotation rounding; the residual std is never taken below this
DEFAULT_FRICTION = 0.0  # a body never seen sliding or bouncing: no friction assumed
DEFAULT_RESTITUTION = 0.0
MAX_IMPACT_DURATION = 0.1  # s: a longer gap between two arcs is not one impact


@dataclass(frozen=True)
class PropertyEstimate:
    """A fitted property: kind friction|restitution|mass_ratio|pair_restitution of ``body_id``
    (mass_ratio and pair_restitution: of ``other_id`` relative to ``body_id``); value, std, measurements."""

    kind: str
    body_id: int
    value: float
    std: float
    measurements: int
    other_id: int | None = None
    phase: int = 0


@dataclass(frozen=True)
class FitReport3D:
    estimates: tuple[PropertyEstimate, ...]

    def get(self, kind: str, body_id: int) -> PropertyEstimate | None:
        for estimate in self.estimates:
            if estimate.kind == kind and estimate.body_id == body_id:
                return estimate
        return None

    def to_dict(self) -> dict:
        return {"estimates": [{"kind": e.kind, "object_id": e.body_id, "other_object_id": e.other_id,
                               "value": round(e.value, 6), "std": round(e.std, 6), "measurements": e.measurements,
                               "phase": e.phase} for e in self.estimates]}


def poly_fit(times: np.ndarray, values: np.ndarray, degree: int) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares polynomial (coefficients ascending, (degree+1,)) and their covariance."""
    design = np.vander(times, degree + 1, increasing=True)
    coef, *_ = np.linalg.lstsq(design, values, rcond=None)
    dof = max(len(times) - degree - 1, 1)
    sigma2 = max(float(np.sum((design @ coef - values) ** 2)) / dof, POSITION_NOISE_FLOOR**2)
    return coef, sigma2 * np.linalg.pinv(design.T @ design)


def _combine(values: list[float], stds: list[float]) -> tuple[float, float]:
    """Several measurements of one property: a random-effects mean (DerSimonian-Laird) and its std.

    When the measurements disagree by more than their fit noise (MuJoCo's soft contact realises a
    different restitution at each impact: wall against floor, fast against slow), plain inverse-variance
    weights let the one best-fitted impact decide and understate the uncertainty. The between-measurement
    variance tau^2 (zero when they agree within their noise) is added to each measurement's variance.
    """
    x = np.asarray(values, float)
    variances = np.maximum(np.asarray(stds, float), 1e-6) ** 2
    weights = 1.0 / variances
    fixed = float(np.sum(weights * x) / np.sum(weights))
    spread = float(np.sum(weights * (x - fixed) ** 2)) - (len(x) - 1)
    scale = float(np.sum(weights) - np.sum(weights**2) / np.sum(weights))
    tau2 = max(spread, 0.0) / scale if scale > 0 else 0.0
    weights = 1.0 / (variances + tau2)
    return float(np.sum(weights * x) / np.sum(weights)), float(1.0 / math.sqrt(np.sum(weights)))


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """[start, stop) index ranges of consecutive True values."""
    runs, start = [], None
    for k, flag in enumerate(list(mask) + [False]):
        if flag and start is None:
            start = k
        elif not flag and start is not None:
            runs.append((start, k))
            start = None
    return runs


def _touching(body: Body3D, faces: list[Face], positions: np.ndarray) -> np.ndarray:
    """(T, F) bool: the body's centre is at contact distance of face f and inside it."""
    out = np.zeros((len(positions), len(faces)), bool)
    for k, face in enumerate(faces):
        local = face_coordinates(face, positions)
        out[:, k] = ((np.abs(local[:, 2] - body.half_size) <= TOUCH_DISTANCE) | ((local[:, 2] < body.half_size) & (local[:, 2] > 0)))
        out[:, k] &= (np.abs(local[:, 0]) <= face.half_u + 1e-3) & (np.abs(local[:, 1]) <= face.half_v + 1e-3)
    return out


def _near_other_bodies(tracks: Tracks3D, phase_index: int, k: int, margin: float = 0.03) -> np.ndarray:
    phase = tracks.phases[phase_index]
    body = _body(tracks, phase.body_ids[k])
    near = np.zeros(len(phase.times), bool)
    for j, other_id in enumerate(phase.body_ids):
        if j == k:
            continue
        gap = gap_between(body, _body(tracks, other_id), phase.positions[:, k], phase.positions[:, j])
        near |= np.nan_to_num(gap, nan=1.0) <= margin
    # a contact disturbs the motion for a frame on either side
    return near | np.roll(near, 1) | np.roll(near, -1)


def _body(tracks: Tracks3D, body_id: int) -> Body3D:
    return next(b for b in tracks.bodies if b.id == body_id)


def _phase_bodies(tracks: Tracks3D, phase_index: int):
    """(index in the phase, body, positions (T, 3) m with NaN where unseen, seen mask (T,)) per body of a phase."""
    phase = tracks.phases[phase_index]
    for k, body_id in enumerate(phase.body_ids):
        positions = phase.positions[:, k]
        yield k, _body(tracks, body_id), positions, np.all(np.isfinite(positions), axis=1)


def _physical_faces(phase) -> list[Face]:
    return [face for box in phase.static_objects if box.role != "zone" for face in box.faces()]


def friction_measurements(tracks: Tracks3D, phase_index: int, gravity: float) -> list[PropertyEstimate]:
    """One friction estimate per sliding run of each body in a phase."""
    phase, faces, g_vec = tracks.phases[phase_index], _physical_faces(tracks.phases[phase_index]), np.array([0.0, 0.0, -gravity])
    out = []
    for k, body, pos, seen in _phase_bodies(tracks, phase_index):
        touching = _touching(body, faces, np.nan_to_num(pos))
        speed = np.linalg.norm(np.gradient(np.nan_to_num(pos), phase.times, axis=0), axis=1)
        free = seen & ~_near_other_bodies(tracks, phase_index, k)
        for f, face in enumerate(faces):
            if face.normal[2] < 0.1:
                continue
            for start, stop in _runs(touching[:, f] & free & (speed > MOVING_SPEED)):
                start, stop = start + EDGE_FRAMES, stop - EDGE_FRAMES
                if stop - start < MIN_SLIDE_FRAMES:
                    continue
                t = phase.times[start:stop] - phase.times[start]
                p = pos[start:stop]
                direction = p[-1] - p[0]
                direction = direction - np.dot(direction, face.normal) * np.asarray(face.normal)
                if np.linalg.norm(direction) < 1e-6:
                    continue
                direction /= np.linalg.norm(direction)
                coef, cov = poly_fit(t, (p - p[0]) @ direction, 2)
                accel, accel_std = 2.0 * coef[2], 2.0 * math.sqrt(cov[2, 2])
                load = gravity * face.normal[2]
                mu = (float(np.dot(g_vec, direction)) - accel) / load
                out.append(PropertyEstimate("friction", body.id, mu, accel_std / load, stop - start, phase=phase_index))
    return out


def _ballistic_fit(times: np.ndarray, positions: np.ndarray, gravity: float):
    """Initial position and velocity (3,) at times[0] of a ballistic arc, their covariance per axis (2x2)."""
    t = times - times[0]
    fall = np.zeros_like(positions)
    fall[:, 2] = -0.5 * gravity * t**2
    coefs, covs = [], []
    for axis in range(3):
        coef, cov = poly_fit(t, positions[:, axis] - fall[:, axis], 1)
        coefs.append(coef)
        covs.append(cov)
    return np.array([c[0] for c in coefs]), np.array([c[1] for c in coefs]), covs


BALLISTIC_TOLERANCE = 2.0  # m/s^2: a second difference further than this from gravity marks an impact


def _split_at_impacts(times: np.ndarray, positions: np.ndarray, flying: np.ndarray, gravity: float):
    """Impacts that fall between frames: a run of second differences that are not gravity.

    Two consecutive odd second differences (k, k+1) mean an impact between frames k and k+1
    (a break, no frame lost); a longer run also drops its inner frames; a single one drops its frame.
    Returns the flying mask and the break indices (an arc may not span k -> k+1 for k in breaks).
    """
    flying = flying.copy()
    odd = np.zeros(len(times), bool)
    if len(times) >= 3:
        dt = np.diff(times)
        second = ((positions[2:] - positions[1:-1]) / dt[1:, None] - (positions[1:-1] - positions[:-2]) / dt[:-1, None])
        second /= 0.5 * (dt[1:] + dt[:-1])[:, None]
        second[:, 2] += gravity
        odd[1:-1] = np.nan_to_num(np.linalg.norm(second, axis=1), nan=0.0) > BALLISTIC_TOLERANCE
    breaks = set()
    for start, stop in _runs(odd):
        if stop - start == 1:
            flying[start] = False
        else:
            flying[start + 1: stop - 1] = False
            breaks.add(start if stop - start == 2 else stop - 2)
    return flying, breaks


def _cut(start: int, stop: int, breaks: set[int]) -> list[tuple[int, int]]:
    """Split [start, stop) after each break index k (k and k+1 end up in different pieces)."""
    pieces, begin = [], start
    for k in sorted(b for b in breaks if start <= b < stop - 1):
        pieces.append((begin, k + 1))
        begin = k + 1
    pieces.append((begin, stop))
    return pieces


def bounce_measurements(tracks: Tracks3D, phase_index: int, gravity: float) -> list[PropertyEstimate]:
    """Restitution (and impact friction) from consecutive ballistic arcs around a static contact."""
    phase, faces, g_vec = tracks.phases[phase_index], _physical_faces(tracks.phases[phase_index]), np.array([0.0, 0.0, -gravity])
    out = []
    for k, body, pos, seen in _phase_bodies(tracks, phase_index):
        flying = seen & ~_touching(body, faces, np.nan_to_num(pos)).any(axis=1) & ~_near_other_bodies(tracks, phase_index, k)
        flying, breaks = _split_at_impacts(phase.times, pos, flying, gravity)
        arcs = [(a, b) for a0, b0 in _runs(flying) for a, b in _cut(a0, b0, breaks) if b - a >= MIN_ARC_FRAMES]
        for (a0, a1), (b0, b1) in zip(arcs, arcs[1:]):
            if b0 - a1 > 2:
                continue  # the arcs must be separated by one short contact
            ta, tb = phase.times[a0:a1], phase.times[b0:b1]
            pa, va, cov_a = _ballistic_fit(ta, pos[a0:a1], gravity)
            pb, vb, cov_b = _ballistic_fit(tb, pos[b0:b1], gravity)
            best = None
            for face in faces:
                n, c = np.asarray(face.normal), np.asarray(face.center)
                # incoming arc: first crossing of the contact plane after its last frame
                d0 = float((pa - c) @ n) - body.half_size
                roots = [r for r in quadratic_roots(0.5 * float(g_vec @ n), float(va @ n), d0) if ta[-1] - ta[0] - 1e-9 <= r <= tb[0] - ta[0] + 1e-9]
                if not roots:
                    continue
                t_in = roots[0]
                p_in = pa + va * t_in + 0.5 * g_vec * t_in**2
                u, v, _ = face_coordinates(face, p_in)
                if abs(u) > face.half_u + body.half_size or abs(v) > face.half_v + body.half_size:
                    continue
                if best is None or t_in < best[1]:
                    best = (face, t_in)
            if best is None:
                continue
            face, t_in = best
            n, c = np.asarray(face.normal), np.asarray(face.center)
            d0 = float((pb - c) @ n) - body.half_size
            back = [r for r in quadratic_roots(0.5 * float(g_vec @ n), float(vb @ n), d0) if ta[-1] - tb[0] - 1e-9 <= r <= 1e-9]
            if not back:
                continue
            t_out = back[-1]
            v_in = va + g_vec * t_in
            v_out = vb + g_vec * t_out
            vn_in, vn_out = float(v_in @ n), float(v_out @ n)
            if vn_in >= -1e-3 or vn_out <= 0:
                continue
            e = -vn_out / vn_in
            # velocity variance: each axis' v0 variance plus its covariance with p0 through the root time is small; keep v0's
            var_in = sum(cov_a[axis][1, 1] * n[axis] ** 2 for axis in range(3))
            var_out = sum(cov_b[axis][1, 1] * n[axis] ** 2 for axis in range(3))
            e_std = abs(e) * math.sqrt(var_in / vn_in**2 + var_out / vn_out**2)
            out.append(PropertyEstimate("restitution", body.id, e, e_std, (a1 - a0) + (b1 - b0), phase=phase_index))
            dv_t = (v_out - vn_out * n) - (v_in - vn_in * n)
            mu = float(np.linalg.norm(dv_t)) / ((1.0 + e) * -vn_in)
            mu_std = math.sqrt(var_in + var_out) / ((1.0 + e) * -vn_in)
            out.append(PropertyEstimate("impact_friction", body.id, mu, mu_std, 1, phase=phase_index))
            duration = (tb[0] + t_out) - (ta[0] + t_in)  # the arcs reach the surface this far apart
            out.append(PropertyEstimate("impact_duration", body.id, duration, 1e-3, 1, phase=phase_index))
    return out


MIN_VELOCITY_CHANGE = 0.02  # m/s: a smaller change across a close approach is a near miss, not a collision
NEAR_GAP = 0.08  # m: a closest approach below this may hide a contact between two frames


def _contact_episodes(gap: np.ndarray) -> list[tuple[int, int]]:
    """[start, stop) frame ranges in contact (gap <= 1 cm), plus empty ranges (k, k) for a close
    approach whose contact fell between frames k - 1 and k (the velocities then tell)."""
    episodes = _runs(gap <= 0.01)
    covered = {k for a, b in episodes for k in range(max(a - 1, 0), b + 1)}
    for k in range(1, len(gap) - 1):
        if gap[k] <= gap[k - 1] and gap[k] <= gap[k + 1] and gap[k] < NEAR_GAP and k not in covered:
            after = k + 1 if gap[k + 1] < gap[k - 1] else k  # the contact lies on the side of the closer neighbour
            episodes.append((after, after))
    return sorted(episodes)


def collision_measurements(tracks: Tracks3D, phase_index: int, window: int = 6) -> list[PropertyEstimate]:
    """Mass ratio m_j / m_i and pair restitution from each body-body contact episode."""
    phase = tracks.phases[phase_index]
    out = []
    ids = phase.body_ids
    for i in range(len(ids)):
        for j in range(i + 1, len(ids)):
            bi, bj = _body(tracks, ids[i]), _body(tracks, ids[j])
            gap = gap_between(bi, bj, np.nan_to_num(phase.positions[:, i], nan=1e3), np.nan_to_num(phase.positions[:, j], nan=-1e3))
            for start, stop in _contact_episodes(gap):
                before = slice(max(start - window, 0), start)
                after = slice(stop, min(stop + window, len(phase.times)))
                if before.stop - before.start < 3 or after.stop - after.start < 3:
                    continue
                t_c = 0.5 * (phase.times[start - 1] + phase.times[stop])  # between the last free frames
                velocities, variances = [], []
                for k in (i, j):
                    for window_slice in (before, after):
                        t = phase.times[window_slice] - t_c
                        p = phase.positions[window_slice, k]
                        degree = 2 if len(t) >= 5 else 1
                        fits = [poly_fit(t, p[:, axis], degree) for axis in range(3)]
                        velocities.append(np.array([coef[1] for coef, _ in fits]))
                        variances.append(np.array([cov[1, 1] for _, cov in fits]))
                vi, vi2, vj, vj2 = velocities
                normal = contact_normal(bi, bj, phase.positions[start - 1, i], phase.positions[start - 1, j])
                dvi, dvj = float((vi2 - vi) @ normal), float((vj2 - vj) @ normal)
                closing = float((vi - vj) @ normal)
                if abs(dvj) < MIN_VELOCITY_CHANGE or closing <= 1e-3:
                    continue
                var = [float(v @ normal**2) for v in variances]
                ratio = -dvi / dvj
                ratio_std = abs(ratio) * math.sqrt((var[0] + var[1]) / max(dvi**2, 1e-12) + (var[2] + var[3]) / dvj**2)
                e = float((vj2 - vi2) @ normal) / closing
                e_std = math.sqrt(var[1] + var[3] + e**2 * (var[0] + var[2])) / closing
                out.append(PropertyEstimate("mass_ratio", ids[i], ratio, ratio_std, 1, other_id=ids[j], phase=phase_index))
                out.append(PropertyEstimate("pair_restitution", ids[i], e, e_std, 1, other_id=ids[j], phase=phase_index))
    return out


def identify_properties(tracks: Tracks3D, phases: tuple[int, ...] | None = None) -> FitReport3D:
    """Every property measurable in the given phases (default all), combined per body (and pair)."""
    chosen = range(len(tracks.phases)) if phases is None else phases
    raw: list[PropertyEstimate] = []
    for p in chosen:
        raw += friction_measurements(tracks, p, tracks.gravity)
        raw += bounce_measurements(tracks, p, tracks.gravity)
        raw += collision_measurements(tracks, p)
    combined = []
    keys = sorted({(e.kind, e.body_id, e.other_id) for e in raw}, key=str)
    for kind, body_id, other_id in keys:
        group = [e for e in raw if (e.kind, e.body_id, e.other_id) == (kind, body_id, other_id)]
        value, std = _combine([e.value for e in group], [e.std for e in group])
        combined.append(PropertyEstimate(kind, body_id, value, std, sum(e.measurements for e in group), other_id,
                                         phase=min(e.phase for e in group)))
    return FitReport3D(tuple(combined))


def world_from_tracks(tracks: Tracks3D, report: FitReport3D, phase_starts: tuple[float, ...],
                      states: tuple[dict[int, State3D], ...], *, fps: float = 25.0, anchor: Anchor3D | None = None,
                      horizon_frames: int | None = None) -> World3D:
    """A World3D whose bodies carry the fitted properties (defaults where nothing was measured),
    the report as ``World3D.fitted``, and the anchor the factual continuation starts from.

    Friction: the sliding fit, else the impact friction, else DEFAULT_FRICTION (clipped to >= 0).
    Restitution: clipped to [0, 1]. Masses: 1 kg for bodies without a ratio, m_j = m_i r_ij otherwise.
    """
    masses = {body.id: 1.0 for body in tracks.bodies}
    for estimate in report.estimates:
        if estimate.kind == "mass_ratio" and estimate.value > 0:
            masses[estimate.other_id] = masses[estimate.body_id] * estimate.value
    bodies = []
    for body in tracks.bodies:
        friction = report.get("friction", body.id) or report.get("impact_friction", body.id)
        restitution = report.get("restitution", body.id)
        duration = report.get("impact_duration", body.id)
        bodies.append(replace(body, mass=masses[body.id],
                              impact_duration=min(max(duration.value, 0.0), MAX_IMPACT_DURATION) if duration else 0.0,
                              friction=max(friction.value, 0.0) if friction else DEFAULT_FRICTION,
                              restitution=min(max(restitution.value, 0.0), 1.0) if restitution else DEFAULT_RESTITUTION))
    pairs = tuple(((e.body_id, e.other_id), min(max(e.value, 0.0), 1.0)) for e in report.estimates if e.kind == "pair_restitution")
    phases = tuple(Phase3D(start, tracks.phases[k].static_objects, tuple(sorted(states[k].items())))
                   for k, start in enumerate(phase_starts))
    fitted = tuple(FittedProperty(e.kind, e.body_id, e.value, e.std, e.measurements, e.other_id) for e in report.estimates)
    return World3D(tuple(bodies), phases, tracks.gravity, pairs, tracks.patient_zone, fps=fps, anchor=anchor,
                   horizon_frames=horizon_frames, fitted=fitted)
