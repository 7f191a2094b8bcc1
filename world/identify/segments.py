"""Candidate collisions from observed tracks, and the stretches between them.

A collision candidate needs two things at once (DESIGN.md, paper Sec. 3.3):
geometric proximity of the two footprints, and a change of velocity of at
least one of the two bodies. Candidates only initialise the joint fit; the
fitted world finds its own contacts by exact root finding.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from world.identify.local_fit import SlideFit, fit_slide
from world.identify.observations import ObjectTrack, Observations

# Footprints whose bounding circles come within this gap (metres, beyond the
# noise allowance) may be touching. Cubes' bounding circles over-reach, so
# proximity alone never decides: a velocity change must confirm it.
CONTACT_MARGIN = 0.06
# Smallest velocity change (m/s) that counts as an impulse.
MIN_DELTA_V = 0.15
# Frames on each side of a candidate used to measure the velocity change.
WINDOW = 8


@dataclass(frozen=True)
class CandidateCollision:
    """A likely collision between ``bodies`` at ``frame``.

    delta_v: (2, 2) observed velocity change (m/s) of each body, in the order
    of ``bodies``; pre / post: (2, 2) velocities just before / after.
    normal: (2,) unit vector from bodies[0] to bodies[1] at contact.
    """

    bodies: tuple[int, int]
    frame: int
    pre: np.ndarray
    post: np.ndarray
    normal: np.ndarray

    @property
    def delta_v(self) -> np.ndarray:
        return self.post - self.pre


def _window_velocity(
    track: ObjectTrack, frames: np.ndarray, at_time: float, fps: float, gravity: float, prior: float
) -> np.ndarray | None:
    """Velocity (2,) m/s at ``at_time`` of a slide fitted on the samples at ``frames``."""
    mask = np.isin(track.frames, frames) & track.observed
    if mask.sum() < 3:
        return None
    fit = fit_slide(track.frames[mask] / fps, track.positions[mask, :2], track.weights[mask], gravity, prior)
    return _velocity_at(fit, at_time, gravity)


def _velocity_at(fit: SlideFit, time: float, gravity: float) -> np.ndarray:
    speed = float(np.hypot(*fit.velocity))
    if speed == 0.0:
        return np.zeros(2)
    remaining = max(speed - fit.friction * gravity * (time - fit.start_time), 0.0)
    return fit.velocity / speed * remaining


def contact_radius(track: ObjectTrack) -> float:
    """Largest footprint reach (m) of the body about its centre."""
    return track.shape.bounding_radius


def find_candidate_collisions(
    observations: Observations, gravity: float = 9.81, friction_prior: float = 0.3
) -> list[CandidateCollision]:
    """Scan every pair for proximity + velocity change; return candidates by frame."""
    fps = observations.fps
    candidates: list[CandidateCollision] = []
    tracks = observations.objects
    for a in range(len(tracks)):
        for b in range(a + 1, len(tracks)):
            ta, tb = tracks[a], tracks[b]
            shared, ia, ib = np.intersect1d(ta.frames, tb.frames, return_indices=True)
            both = ta.observed[ia] & tb.observed[ib]
            if not both.any():
                continue
            shared, ia, ib = shared[both], ia[both], ib[both]
            offset = tb.positions[ib, :2] - ta.positions[ia, :2]
            gap = np.hypot(offset[:, 0], offset[:, 1]) - (contact_radius(ta) + contact_radius(tb))
            close = gap <= CONTACT_MARGIN
            if not close.any():
                continue
            # Each run of close frames is one candidate contact episode.
            edges = np.flatnonzero(np.diff(np.concatenate([[0], close.astype(np.int8), [0]])))
            for start, stop in zip(edges[::2], edges[1::2]):
                run = slice(start, stop)
                pick = start + int(np.argmin(gap[run]))
                frame = int(shared[pick])
                # Skip the contact frame itself: it may hold either side.
                before = np.arange(frame - WINDOW, frame)
                after = np.arange(frame + 1, frame + WINDOW + 1)
                velocities = []
                for track in (ta, tb):
                    v_before = _window_velocity(track, before, frame / fps, fps, gravity, friction_prior)
                    v_after = _window_velocity(track, after, frame / fps, fps, gravity, friction_prior)
                    velocities.append((v_before, v_after))
                if any(v is None for pair in velocities for v in pair):
                    continue
                pre = np.array([velocities[0][0], velocities[1][0]])
                post = np.array([velocities[0][1], velocities[1][1]])
                change = np.hypot(*(post - pre).T)
                if change.max() < MIN_DELTA_V:
                    continue
                normal = offset[pick] / max(np.hypot(*offset[pick]), 1e-9)
                candidates.append(CandidateCollision((ta.id, tb.id), frame, pre, post, normal))
    candidates.sort(key=lambda c: (c.frame, c.bodies))
    return candidates

