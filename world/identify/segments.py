"""Candidate collisions from observed tracks.

A collision candidate needs two things at once (DESIGN.md, paper Sec. 3.3):
a change of velocity of a body (a change point of its track) and, at that
frame, another body whose footprint is close enough to touch it. Candidates
only initialise the joint fit and split tracks into stretches for the local
fits; the fitted world finds its own contacts by exact root finding.
Precise tracks (oracle positions, ``precise_tracks``) need no change point: two
of them collided where their footprints touched (``touch_events``), which
also finds glancing contacts and contacts with a body at rest. They are
also the world's record of observed collisions (World.observed_collisions).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from world.footprint import footprint_gap
from world.identify.local_fit import fit_slide
from world.observations import ObjectTrack, Observations
from world.timebase import CONTACT_EPISODE_GAP_SECONDS, frame_of
from world.types import Shape

# Footprints whose bounding circles come within this gap (metres) at a
# change point may be touching. Cubes' bounding circles over-reach, so
# proximity alone never decides: the velocity change must be there too.
CONTACT_MARGIN = 0.08
# Smallest velocity change (m/s) that counts as an impulse: well above the
# ~0.04 m/s a frame of friction removes and the noise of window fits.
MIN_DELTA_V = 0.15
# Frames on each side of a frame used to measure its velocity change.
WINDOW = 6
# Change points of one body closer than this (frames) are one event.
MIN_SEPARATION = 4
# Largest deceleration (m/s^2) friction alone may cause: sliding or rolling
# objects on a tabletop stay well below mu = 0.12.
MAX_FRICTION_DECELERATION = 1.2
# Frames a track may miss and still be one run: perception often loses one
# of two touching objects for a frame or two right at their contact (the two
# read as one segment), exactly where the change point is.
MAX_BRIDGED_GAP = 3
REACH_FRAMES = 6  # frames from a partner's nearest sample over which it may have met a body unseen (_gap's unseen_on_course)
# A pair closing in at least this fast (m/s, along the line between their
# centres) whose closing speed then drops by MIN_DELTA_V while they touch
# collided, even when neither track alone shows a clear change point (noisy
# perceived tracks, a light hit on a heavy partner).
MIN_APPROACH_SPEED = 0.1
# Rigid bodies do not interpenetrate: two tracks whose centres come closer
# than their footprints' inscribed radii allow, by more than this (m, about
# the worst perceived error at a contact), are one object tracked twice (a
# fragment track of perception), never a contact.
INTERPENETRATION_TOLERANCE = 0.15
# Tracks whose median |third difference| of plane positions is at most this
# (m) are precise enough to see a touch: constant deceleration has no third
# difference, so what is left is measurement error (about 4.5 x its standard
# deviation). Oracle tracks (rounded to 0.1 mm) give ~0.1 mm; 1 % of an
# object's size of noise gives ~12 mm.
PRECISE_TRACK_JITTER = 0.002
# Third differences measure the error only where the object moves: each step of a 4-sample window
# longer than this (m per frame, 5 cm/s at 25 fps). A resting object that perception re-fits to the
# same pixels repeats one position exactly (jitter 0), which says nothing of how far off it is.
MOVING_STEP = 0.002
# Moving windows a track needs to be judged on its own (a collision or a launch gives a few windows
# of large real third differences; the median of this many is the measurement's); with fewer, the
# moving windows of all the observations' tracks judge it (one measurement process made them all).
MIN_MOVING_WINDOWS = 12
# Two precise tracks whose footprints (true sizes, cube yaw) come within this
# gap (m), at a frame or between two (each body continuing its last frame's
# motion), touch: a collision however little either velocity changes.
# Covers the rounding of positions (0.1 mm) and of the yaw of a cube.
TOUCH_GAP = 0.0015
# Perceived tracks whose footprints (fitted cube yaw) come within this gap (m) show the two touching
# (seen_touching): a perceived centre is 1-2 cm off (p90), so two of them may be 3 cm apart at a touch.
SEEN_TOUCH_GAP = 0.03
# Sub-frame times (share of a frame after each frame) at which the motion
# continued from the frame is tested for a touch between two frames.
SUB_FRAME_STEPS = (0.25, 0.5, 0.75)
# Samples a side needs to show a body at rest, or moving, around an unexplained start (unexplained_start);
# the local fit's own count for a rest start (fit._initial_estimates).
MIN_REST_SAMPLES = 3


@dataclass(frozen=True)
class CandidateCollision:
    """A likely collision between ``bodies`` at ``frame``.

    pre / post: (2, 2) velocities (m/s) of each body just before / after,
    in the order of ``bodies``; a row of NaN where that side was not seen
    (e.g. a body that enters the view right at the contact).
    normal: (2,) unit vector from bodies[0] to bodies[1] at contact.
    corroborated: False when one track alone shows the impulse (a change point
    of one body, its partner the closest touching body with no change point
    of its own and no pair event) or the pair's closing speed alone does (a
    pair event, no change point): weak evidence, which the record of
    observed collisions keeps only where the fitted replay makes the pair
    collide (fit.recorded_collisions).
    """

    bodies: tuple[int, int]
    frame: int
    pre: np.ndarray
    post: np.ndarray
    normal: np.ndarray
    corroborated: bool = True

    @property
    def delta_v(self) -> np.ndarray:
        return self.post - self.pre

    @property
    def event(self) -> tuple[int, int, int]:
        """(a, b, frame), a < b: the collision as World.observed_collisions holds it."""
        return min(self.bodies), max(self.bodies), self.frame


def _runs(frames: np.ndarray, max_gap: int = MAX_BRIDGED_GAP) -> list[np.ndarray]:
    """Split sorted frame ids into runs with at most ``max_gap`` missing frames between neighbours."""
    if frames.size == 0:
        return []
    cuts = np.flatnonzero(np.diff(frames) > max_gap + 1) + 1
    return np.split(frames, cuts)


def _weighted_slope(times: np.ndarray, xy: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Weighted least-squares velocity (2,) m/s of samples (times (n,) s, xy (n, 2) m); NaN if undetermined."""
    total = weights.sum()
    if times.size < 2 or total <= 0:
        return np.full(2, np.nan)
    t = times - (weights @ times) / total
    spread = (weights * t) @ t
    if spread <= 1e-12:
        return np.full(2, np.nan)
    return ((weights * t) @ (xy - (weights @ xy) / total)) / spread


def window_velocities(
    frames: np.ndarray, xy: np.ndarray, weights: np.ndarray, fps: float, at_frames: np.ndarray, window: int = WINDOW
) -> tuple[np.ndarray, np.ndarray]:
    """Weighted least-squares velocity (m/s) just before and just after each of ``at_frames``.

    frames: (T,) sorted frame ids of the samples; xy: (T, 2) m; weights: (T,)
    confidence (a perceived sample of a merged or cut segment counts less);
    at_frames: (K,). "Before" uses the samples of the ``window`` frames before
    a frame, "after" those of the ``window`` frames after it; the frame itself
    is in neither (it may straddle the contact) and missing frames simply
    have no sample. Returns before, after: (K, 2), NaN where a side has
    fewer than 2 samples.
    """
    before = np.full((at_frames.size, 2), np.nan)
    after = np.full((at_frames.size, 2), np.nan)
    for k, frame in enumerate(at_frames):
        for side, low, high in ((before, frame - window, frame - 1), (after, frame + 1, frame + window)):
            use = (frames >= low) & (frames <= high)
            if use.sum() >= 2:
                side[k] = _weighted_slope(frames[use] / fps, xy[use], weights[use])
    return before, after


def change_points(track: ObjectTrack, fps: float) -> list[int]:
    """Frames where the body's velocity jumps by at least MIN_DELTA_V (m/s)."""
    frames = track.frames[track.observed]
    positions = track.positions[track.observed, :2]
    weights = track.weights[track.observed]
    points: list[int] = []
    offset = 0
    for run in _runs(frames):
        xy, w = positions[offset : offset + run.size], weights[offset : offset + run.size]
        offset += run.size
        before, after = window_velocities(run, xy, w, fps, run)
        jump = impulse_strength(before, after, (WINDOW + 1) / fps)
        # One impulse raises the jump on every frame whose windows straddle
        # it, peaking at the contact: keep local maxima, strongest first,
        # kept MIN_SEPARATION apart.
        padded = np.concatenate([[-1.0], jump, [-1.0]])
        peak = (jump >= padded[:-2]) & (jump >= padded[2:]) & (jump >= MIN_DELTA_V)
        chosen: list[int] = []
        for k in np.flatnonzero(peak)[np.argsort(-jump[peak], kind="stable")]:
            if all(abs(k - c) >= MIN_SEPARATION for c in chosen):
                chosen.append(int(k))
        points += [int(run[k]) for k in sorted(chosen)]
    return points


def impulse_strength(before: np.ndarray, after: np.ndarray, span: float) -> np.ndarray:
    """How much of a velocity change friction cannot explain (m/s).

    before, after: (T, 2) window velocities (m/s), NaN where unknown; span:
    seconds between the windows' centres. Friction only slows a body along
    its direction of motion, by at most MAX_FRICTION_DECELERATION * span;
    anything sideways, any speed-up, or a larger slow-down needs an impulse.
    Returns (T,), 0 where unknown.
    """
    delta = after - before
    speed = np.linalg.norm(before, axis=1)
    direction = before / np.maximum(speed, 1e-9)[:, None]
    along = np.sum(delta * direction, axis=1)
    sideways = np.abs(delta[:, 0] * direction[:, 1] - delta[:, 1] * direction[:, 0])
    allowance = np.minimum(MAX_FRICTION_DECELERATION * span, speed)
    slow_down = np.maximum(-along - allowance, 0.0)
    strength = np.sqrt(sideways**2 + slow_down**2 + np.maximum(along, 0.0) ** 2)
    return np.where(np.isfinite(strength), strength, 0.0)


def contact_radius(track: ObjectTrack) -> float:
    """Largest footprint reach (m) of the body about its centre."""
    return track.shape.bounding_radius


def _inscribed_radius(track: ObjectTrack) -> float:
    """Radius (m) of the largest circle about the centre inside the footprint."""
    return track.shape.half_extent if track.shape.kind == "cube" else track.shape.radius


def _one_object_twice(track: ObjectTrack, other: ObjectTrack, frame: int) -> bool:
    """True when the two centres at ``frame`` are closer than two rigid bodies can be (see INTERPENETRATION_TOLERANCE)."""
    here, there = _position_at(track, frame), _position_at(other, frame)
    if here is None or there is None:
        return False
    reach = _inscribed_radius(track) + _inscribed_radius(other) - INTERPENETRATION_TOLERANCE
    return float(np.hypot(*(there - here))) < reach


def _gap(track: ObjectTrack, other: ObjectTrack, frame: int, *, unseen_on_course: bool = False) -> float:
    """Smallest gap (m) between the two bounding circles within +-2 frames of ``frame``; inf where no probe
    frame places both (unseen, and with ``unseen_on_course`` no straight course within reach either).

    Change points of fast impacts land a frame or two off the contact
    (a body at 4 m/s moves 16 cm a frame), so a short window is searched.
    unseen_on_course: a side the track does not show at a probe frame (its segment lost in the contact:
    more than MAX_BRIDGED_GAP frames missing) stands where its straight course into or out of the hole
    puts it (``_courses_into``), instead of nowhere.
    """
    best = float("inf")
    for probe in range(frame - 2, frame + 3):
        sides = []
        for body in (track, other):
            seen = _position_at(body, probe)
            sides.append([seen] if seen is not None else _courses_into(body, probe) if unseen_on_course else [])
        for here in sides[0]:
            for there in sides[1]:
                best = min(best, float(np.hypot(*(there - here))) - contact_radius(track) - contact_radius(other))
    return best


def _courses_into(track: ObjectTrack, frame: int) -> list[np.ndarray]:
    """(2,) m positions of a body at ``frame`` where its track does not show it (a hole, or before its first
    or after its last sample): its straight course into that stretch (from the last two samples before, at
    most REACH_FRAMES back) and out of it (from the first two after, backwards); a body's course is straight
    up to the contact and from it on. Empty when neither side has two samples within reach."""
    frames = track.frames[track.observed]
    positions = track.positions[track.observed, :2]
    index = int(np.searchsorted(frames, frame))
    courses = []
    for last, previous in ((index - 1, index - 2), (index, index + 1)):
        if 0 <= min(last, previous) and max(last, previous) < frames.size and abs(int(frames[last]) - frame) <= REACH_FRAMES:
            velocity = (positions[last] - positions[previous]) / (frames[last] - frames[previous])  # m per frame
            courses.append(positions[last] + velocity * (frame - frames[last]))
    return courses


def seen_touching(track: ObjectTrack, other: ObjectTrack, frame: int) -> bool:
    """The two tracks show their bodies touching near ``frame``: footprints within SEEN_TOUCH_GAP on a frame
    within +-2 of it where both are seen (a cube's square at its track's yaw; its bounding circle where the
    track has no yaw there). Bounding circles would over-reach: two cubes face to face 15 cm apart have
    touching bounding circles."""
    for probe in range(frame - 2, frame + 3):
        here, there = _position_at(track, probe), _position_at(other, probe)
        if here is None or there is None:
            continue
        shapes, yaws = zip(*(_footprint_at(body, probe) for body in (track, other)))
        gap = footprint_gap(shapes[0], np.array([[*here, 0.0]]), np.array([yaws[0]]),
                            shapes[1], np.array([[*there, 0.0]]), np.array([yaws[1]]))
        if float(gap[0]) <= SEEN_TOUCH_GAP:
            return True
    return False


def _footprint_at(track: ObjectTrack, frame: int) -> tuple[Shape, float]:
    """The body's footprint shape and yaw (rad) near ``frame``: a cube's yaw from its nearest observed sample;
    a cube without one there stands for its bounding circle."""
    if track.shape.kind != "cube":
        return track.shape, 0.0
    frames = track.frames[track.observed]
    yaw = float(track.yaw[track.observed][np.argmin(np.abs(frames - frame))]) if frames.size else float("nan")
    if np.isfinite(yaw):
        return track.shape, yaw
    return Shape("cylinder", radius=track.shape.bounding_radius, half_height=track.shape.half_extent), 0.0


def _position_at(track: ObjectTrack, frame: int) -> np.ndarray | None:
    """(2,) m: the observed position at ``frame``, or the straight line between the observed
    samples around it when at most MAX_BRIDGED_GAP frames are missing there; None otherwise."""
    frames = track.frames[track.observed]
    index = int(np.searchsorted(frames, frame))
    if index < frames.size and frames[index] == frame:
        return track.positions[track.observed][index, :2]
    if index == 0 or index == frames.size or frames[index] - frames[index - 1] > MAX_BRIDGED_GAP + 1:
        return None
    low, high = frames[index - 1], frames[index]
    share = (frame - low) / (high - low)
    positions = track.positions[track.observed]
    return (1 - share) * positions[index - 1, :2] + share * positions[index, :2]


def _contact_lasts(first: ObjectTrack, second: ObjectTrack, start: int, end: int) -> bool:
    """The two bodies stay within CONTACT_MARGIN (bounding circles) on every frame from ``start`` to ``end``
    where both are seen."""
    gaps = (_gap(first, second, probe) for probe in range(start, end + 1))
    return all(gap <= CONTACT_MARGIN for gap in gaps if np.isfinite(gap))


def contact_episode_starts(candidates: list[CandidateCollision], observations: Observations,
                           precise: frozenset[int]) -> list[CandidateCollision]:
    """The candidates less those of a pair of perceived (not precise) tracks whose earlier candidate's contact
    lasted until them: bodies that never separated did not collide again (MuJoCo, the engine and the truth
    count one collision per contact episode). Noisy tracks in a cluster of touching objects, or a push that
    lasts several frames, give one pair change points a few frames apart: fitted as impulses they explain
    the motion, but they are one collision of the record. Pairs of precise tracks are counted by touch
    episodes already (touch_events); precise: precise_tracks(observations)."""
    tracks = {t.id: t for t in observations.objects}
    kept, earlier = [], {}
    for candidate in sorted(candidates, key=lambda c: (c.frame, c.bodies)):
        first, second = candidate.bodies
        previous = earlier.get(candidate.bodies)
        earlier[candidate.bodies] = candidate.frame
        if previous is not None and not (first in precise and second in precise) and _contact_lasts(
                tracks[first], tracks[second], previous, candidate.frame):
            continue
        kept.append(candidate)
    return kept


def approach_events(first: ObjectTrack, second: ObjectTrack, fps: float) -> list[int]:
    """Frames where two bodies touch while their closing speed drops: a collision seen from the pair.

    Per contact episode (frames whose bounding circles come within
    CONTACT_MARGIN), the frame of closest approach is kept when, from the
    weighted window velocities of both tracks, the pair was closing at
    >= MIN_APPROACH_SPEED along the line between their centres and the
    closing speed then fell by >= MIN_DELTA_V. Both tracks' noise averages
    in one relative velocity, so this finds hits whose per-body change points
    drown in perception noise.
    """
    shared = np.intersect1d(first.frames[first.observed], second.frames[second.observed])
    if shared.size == 0:
        return []
    span = np.arange(int(shared[0]), int(shared[-1]) + 1)
    reach = contact_radius(first) + contact_radius(second)
    gaps = np.full(span.size, np.inf)
    centres = {}
    for k, frame in enumerate(span):
        here, there = _position_at(first, int(frame)), _position_at(second, int(frame))
        if here is not None and there is not None:
            gaps[k] = float(np.hypot(*(there - here))) - reach
            centres[int(frame)] = (here, there)
    events: list[int] = []
    touching = gaps <= CONTACT_MARGIN
    for episode in _runs(span[touching], max_gap=0):
        frame = int(episode[np.argmin(gaps[np.isin(span, episode)])])
        if _one_object_twice(first, second, frame):
            continue
        here, there = centres[frame]
        normal = (there - here) / max(float(np.hypot(*(there - here))), 1e-9)
        sides = []
        for track in (first, second):
            use = track.observed
            sides.append(window_velocities(track.frames[use], track.positions[use, :2], track.weights[use], fps, np.array([frame])))
        closing_before = float((sides[0][0][0] - sides[1][0][0]) @ normal)
        closing_after = float((sides[0][1][0] - sides[1][1][0]) @ normal)
        if closing_before >= MIN_APPROACH_SPEED and closing_before - closing_after >= MIN_DELTA_V:
            events.append(frame)
    return events


def _side_velocity(
    track: ObjectTrack, frames: np.ndarray, at_time: float, fps: float, gravity: float, prior: float
) -> np.ndarray:
    """Velocity (2,) m/s at ``at_time`` of a slide fitted on the samples at ``frames``; NaN if < 2."""
    mask = np.isin(track.frames, frames) & track.observed
    if mask.sum() < 2:
        return np.full(2, np.nan)
    fit = fit_slide(track.frames[mask] / fps, track.positions[mask, :2], track.weights[mask], gravity, prior)
    return fit.state_at(at_time, gravity)[1]


def _jitter(track: ObjectTrack) -> tuple[np.ndarray, np.ndarray]:
    """|third difference| (m) of the plane positions over every 4-sample window of consecutive observed
    frames, and whether each window moves (all three steps > MOVING_STEP); both (W,)."""
    frames = track.frames[track.observed]
    xy = track.positions[track.observed, :2]
    jitter, moving = [np.zeros(0)], [np.zeros(0, bool)]
    for run in _runs(frames, max_gap=0):
        if run.size >= 4:
            rows = np.searchsorted(frames, run)
            steps = np.linalg.norm(np.diff(xy[rows], axis=0), axis=1)
            jitter.append(np.linalg.norm(np.diff(xy[rows], n=3, axis=0), axis=1))
            moving.append((steps[:-2] > MOVING_STEP) & (steps[1:-1] > MOVING_STEP) & (steps[2:] > MOVING_STEP))
    return np.concatenate(jitter), np.concatenate(moving)


def precise_tracks(observations: Observations) -> frozenset[int]:
    """Ids of the tracks precise enough for the touch test (median jitter <= PRECISE_TRACK_JITTER).

    A track is judged on its moving windows (``_jitter``); one with fewer than MIN_MOVING_WINDOWS
    (an object at rest most of the video) by the moving windows of all the tracks, which one
    measurement process made (perception, an annotation); when nothing moves, by all its windows.
    A track without a window of its own (never 4 consecutive samples) is not precise.
    """
    measured = {t.id: _jitter(t) for t in observations.objects}
    pooled = np.concatenate([jitter[moving] for jitter, moving in measured.values()] + [np.zeros(0)])
    precise = set()
    for track_id, (jitter, moving) in measured.items():
        if moving.sum() >= MIN_MOVING_WINDOWS:
            evidence = jitter[moving]
        elif jitter.size and pooled.size >= MIN_MOVING_WINDOWS:
            evidence = pooled
        else:
            evidence = jitter  # no window of its own (under 4 consecutive samples): never precise
        if evidence.size and float(np.median(evidence)) <= PRECISE_TRACK_JITTER:
            precise.add(track_id)
    return frozenset(precise)


def _dense(track: ObjectTrack, num_frames: int) -> tuple[np.ndarray, np.ndarray]:
    """(num_frames, 3) observed positions (m, NaN where not observed) and (num_frames,) yaw (rad, 0 where unknown)."""
    positions = np.full((num_frames, 3), np.nan)
    yaw = np.zeros(num_frames)
    use = track.observed & (track.frames < num_frames)
    positions[track.frames[use]] = track.positions[use]
    yaw[track.frames[use]] = np.nan_to_num(track.yaw[use])
    return positions, yaw


def _carried_touch(
    first: ObjectTrack, second: ObjectTrack, pa: np.ndarray, ya: np.ndarray, pb: np.ndarray, yb: np.ndarray,
    frames: np.ndarray, step: int,
) -> np.ndarray:
    """Share of a frame after which the pair, carried on from ``frames`` with the motion between
    ``frames - step`` and ``frames``, first touches; NaN where it does not within SUB_FRAME_STEPS. (len(frames),).

    The share is where the footprint gap crosses zero, interpolated linearly
    between the last step still apart and the first touching one (the gap of
    two bodies in straight motion is nearly linear over a fraction of a
    frame), not the first touching step, which would put every hidden touch
    late by up to a step.
    """
    shares = np.full(frames.size, np.nan)
    previous_share = 0.0
    previous_gap = footprint_gap(first.shape, pa[frames], ya[frames], second.shape, pb[frames], yb[frames])
    for share in SUB_FRAME_STEPS:
        ahead_a = pa[frames] + share * (pa[frames] - pa[frames - step])
        ahead_b = pb[frames] + share * (pb[frames] - pb[frames - step])
        gap = footprint_gap(first.shape, ahead_a, ya[frames], second.shape, ahead_b, yb[frames])
        touch = (gap <= TOUCH_GAP) & np.isnan(shares)
        closing = np.maximum(previous_gap - gap, 1e-12)
        crossing = previous_share + (share - previous_share) * np.clip(previous_gap / closing, 0.0, 1.0)
        shares[touch] = crossing[touch]
        previous_share, previous_gap = share, gap
    return shares


def touch_times(first: ObjectTrack, second: ObjectTrack, num_frames: int) -> np.ndarray:
    """Times (in frames, sorted) at which the pair's footprints touch (gap <= TOUCH_GAP).

    Every frame both bodies are seen touching, and a touch hidden between two
    frames k and k+1 that do not touch: each body continuing its motion from
    k-1 to k (the motion before the contact carried forward), or its motion
    from k+2 to k+1 (the motion after it carried back), overlaps there. A
    carried motion must not itself span a contact of the pair (it would
    overlap by the bounce): forward needs no touch in (k-1, k], backward none
    at k+2. The backward test also sees a contact just before a body entered
    the view, or one right after a third body set it moving. Yaw is held.
    """
    pa, ya = _dense(first, num_frames)
    pb, yb = _dense(second, num_frames)
    seen = np.isfinite(pa[:, 0]) & np.isfinite(pb[:, 0])
    at = np.flatnonzero(seen)
    touching = np.zeros(num_frames, dtype=bool)
    if at.size == 0:
        return np.zeros(0)
    touching[at] = footprint_gap(first.shape, pa[at], ya[at], second.shape, pb[at], yb[at]) <= TOUCH_GAP
    forward = np.full(num_frames, np.nan)  # share after k of a touch carried forward from k
    backward = np.full(num_frames, np.nan)  # share before k+1 of a touch carried back from k+1
    frames = np.flatnonzero(seen[1:] & seen[:-1]) + 1  # seen with the frame before
    forward[frames] = _carried_touch(first, second, pa, ya, pb, yb, frames, 1)
    frames = frames - 1  # seen with the frame after
    backward[frames[frames >= 1] - 1] = _carried_touch(first, second, pa, ya, pb, yb, frames[frames >= 1], -1)
    times = [float(k) for k in np.flatnonzero(touching)]
    hidden_before = False  # a touch hidden in the previous interval
    for k in range(num_frames):
        # The interval (k, k+1); past the last frame only the forward test (a touch rounding to the last frame).
        found = None
        apart = not touching[k] and not (k + 1 < num_frames and touching[k + 1])
        if apart and k >= 1 and not touching[k - 1] and not hidden_before and np.isfinite(forward[k]):
            found = k + forward[k]
        if apart and k + 2 < num_frames and not touching[k + 2] and np.isfinite(backward[k]):
            found = min(found if found is not None else np.inf, k + 1 - backward[k])
        if found is not None:
            times.append(float(found))
        hidden_before = found is not None
    return np.array(sorted(times))


def touch_events(first: ObjectTrack, second: ObjectTrack, num_frames: int, fps: float) -> list[int]:
    """Frames where two precise tracks start touching (TOUCH_GAP): one per contact episode.

    As the engine and MuJoCo's ground truth count them: a touch more than
    CONTACT_EPISODE_GAP_SECONDS after the pair's previous touch is a new
    collision, at the frame of its first (sub-frame) touch; a touch whose
    frame is outside the video (it rounds to the frame after it) is not one.
    """
    episode_gap = CONTACT_EPISODE_GAP_SECONDS * fps  # frames
    events: list[int] = []
    previous = -np.inf
    for time in touch_times(first, second, num_frames):
        if time - previous > episode_gap:
            frame = frame_of(time / fps, fps)
            if 0 <= frame < num_frames:
                events.append(frame)
        previous = time
    return events


def find_candidate_collisions(
    observations: Observations, gravity: float = 9.81, friction_prior: float = 0.3
) -> list[CandidateCollision]:
    """Candidate collisions, one per pair and event.

    A pair of precise tracks (``precise_tracks``) collides where their footprints
    touch (``touch_events``): geometry sees every contact, a glancing one or
    one with a body at rest included, and never a near miss. Other pairs:
    change points matched to the closest touching partner, and pair events
    (``approach_events``).
    """
    fps = observations.fps
    tracks = {t.id: t for t in observations.objects}
    precise_ids = precise_tracks(observations)
    precise = {t.id: t.id in precise_ids for t in observations.objects}
    points = {t.id: change_points(t, fps) for t in observations.objects}
    # (pair, frame) -> what shows the collision: a touch of precise tracks, both bodies' change points,
    # one body's change point (the partner the closest touching body), the pair's closing speed.
    found: dict[tuple[tuple[int, int], int], set[str]] = {}

    def add(pair: tuple[int, int], frame: int, evidence: str) -> None:
        for (p, f), kinds in found.items():
            if p == pair and abs(f - frame) < MIN_SEPARATION:
                kinds.add(evidence)  # one event: its evidence adds up
                return
        found[(pair, frame)] = {evidence}

    ids = sorted(tracks)
    for i, first in enumerate(ids):
        for second in ids[i + 1 :]:
            if precise[first] and precise[second]:
                for frame in touch_events(tracks[first], tracks[second], observations.num_frames, fps):
                    add((first, second), frame, "touch")
    for body, frames in points.items():
        track = tracks[body]
        for frame in frames:
            touching = {
                other_id: gap
                for other_id, other in tracks.items()
                if other_id != body and not (precise[body] and precise[other_id])
                and (gap := _gap(track, other, frame, unseen_on_course=True)) <= CONTACT_MARGIN
                and not _one_object_twice(track, other, frame)
            }
            # Partners that felt the impulse too (a change point of their
            # own) are the collision; if none did (a much heavier partner
            # barely moves), the closest touching body is.
            felt = [o for o in touching if any(abs(f - frame) < MIN_SEPARATION for f in points[o])]
            partners = felt or ([min(touching, key=touching.get)] if touching else [])
            for other_id in partners:
                add((min(body, other_id), max(body, other_id)), frame, "both" if felt else "one")
    for i, first in enumerate(ids):
        for second in ids[i + 1 :]:
            if not (precise[first] and precise[second]):
                for frame in approach_events(tracks[first], tracks[second], fps):
                    add((first, second), frame, "pair")
    candidates = []
    for (pair, frame), evidence in sorted(found.items(), key=lambda item: (item[0][1], item[0][0])):
        pre, post = [], []
        for body in pair:
            # Each side's window stops at the body's neighbouring change points.
            neighbours = [f for f in points[body] if f != frame]
            low = max([f for f in neighbours if f < frame] + [frame - 2 * WINDOW])
            high = min([f for f in neighbours if f > frame] + [frame + 2 * WINDOW])
            pre.append(_side_velocity(tracks[body], np.arange(low + 1, frame), frame / fps, fps, gravity, friction_prior))
            post.append(_side_velocity(tracks[body], np.arange(frame + 1, high), frame / fps, fps, gravity, friction_prior))
        a, b = _position_at(tracks[pair[0]], frame), _position_at(tracks[pair[1]], frame)
        if a is None or b is None:
            a = tracks[pair[0]].positions[np.argmin(np.abs(tracks[pair[0]].frames - frame)), :2]
            b = tracks[pair[1]].positions[np.argmin(np.abs(tracks[pair[1]].frames - frame)), :2]
        offset = b - a
        normal = offset / max(float(np.hypot(*offset)), 1e-9)
        corroborated = bool(evidence & {"touch", "both"}) or evidence >= {"one", "pair"}
        candidates.append(CandidateCollision(pair, frame, np.array(pre), np.array(post), normal, corroborated))
    return candidates


def unexplained_start(track: ObjectTrack, observed_tracks: Sequence[ObjectTrack], candidates: Sequence[CandidateCollision],
                      fps: float, gravity: float = 9.81, friction_prior: float = 0.3) -> int | None:
    """The frame at which a body seen at rest starts to move with no collision of its own to explain it (a
    launch, or a hit by a body the tracks do not show), else None.

    The world moves a body only by collisions: fitted as one slide, the rest and the motion average into a
    path that is neither (metres off both). The start is the first change point after which the body moves
    (a slide fit with non-zero velocity up to its next change point, reaching farther than its own
    contact_radius from where it rested by then) while it was at rest before (zero velocity, the local fit's
    own test), each side seen on at least MIN_REST_SAMPLES samples; change points of noise at rest are
    passed over. None when a candidate collision of the body comes first (before the start's event ends,
    MIN_SEPARATION frames), when the body moved before, or when another of ``observed_tracks`` comes within
    one width of it at the start (bounding circles closer than twice its contact_radius, +-2 frames).
    """
    points = change_points(track, fps)

    def moves(inside: np.ndarray) -> bool | None:
        if inside.sum() < MIN_REST_SAMPLES:
            return None
        return bool(np.any(fit_slide(track.frames[inside] / fps, track.positions[inside, :2], track.weights[inside],
                                     gravity, friction_prior).velocity))

    for start, following in zip(points, [*points[1:], int(track.frames[-1]) + 2]):
        if any(track.id in c.bodies and c.frame < start + MIN_SEPARATION for c in candidates):
            return None
        resting = track.observed & (track.frames < start - 1)
        moved_before = moves(resting)
        if moved_before is None:
            continue
        if moved_before:
            return None
        after = track.observed & (track.frames > start + 1) & (track.frames < following - 1)
        rest = np.median(track.positions[resting, :2], axis=0)
        # Noise at rest can pass for motion in a slide fit; a start carries the body beyond its own reach
        # before anything else happens to it.
        travels = float(np.max(np.hypot(*(track.positions[after, :2] - rest).T), initial=0.0)) > contact_radius(track)
        if travels and moves(after):
            # A body within one width of it may have hit it where the change points missed the contact
            # (mistimed, or its track lost there): left to the fit.
            others = (o for o in observed_tracks if o.id != track.id)
            near = any(_gap(track, other, start) <= 2 * contact_radius(track) for other in others)
            return None if near else start
    return None
