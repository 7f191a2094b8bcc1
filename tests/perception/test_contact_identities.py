"""Identities at a contact of two same-looking objects (pipeline._untangle_contacts).

The frame-to-frame tracker predicts through a contact at constant velocity; in a head-on hit the
mover stops and the one hit goes on, so the tracks come out of the contact holding each other's
object. The whole-track check joins each object's motion before the contact to the motion after
it that meets it. Tracks are built here sample by sample (positions on the plane, 5 mm noise,
weights as the lifter gives them: 1 when alone, 0.3 when carved out of a shared segment).
"""

from __future__ import annotations

import numpy as np

from perception.pipeline import _untangle_contacts
from perception.types import Attributes, LiftedTrack

SIZE = 0.2  # m, object radius (world.observations.DEFAULT_OBJECT_SIZE)
FRAMES = np.arange(60)
CONTACT = 20  # frame of the hit
MERGED = range(CONTACT, CONTACT + 5)  # frames where both objects are one segment
RED = np.array([0.6, 0.2, 0.2, 0.0])  # appearance: chromaticity + hue-less share, the same for both


def _track(track_id: int, xy: np.ndarray, seed: int, merged: range = MERGED) -> LiftedTrack:
    rng = np.random.default_rng(seed)
    positions = np.column_stack([xy + rng.normal(0.0, 0.005, xy.shape), np.full(len(xy), SIZE)])
    weights = np.where(np.isin(FRAMES, list(merged)), 0.3, 1.0)
    attributes = Attributes("red", "cylinder", "rubber", 1.0, shape_score=0.9)
    return LiftedTrack(track_id, attributes, FRAMES.copy(), positions, np.full(len(xy), np.nan), np.ones(len(xy), bool), weights)


def _head_on() -> tuple[np.ndarray, np.ndarray]:
    """(60, 2) paths of a mover that stops at the hit and of the body at rest it sets going."""
    t = FRAMES.astype(float)
    mover = np.column_stack([np.where(t < CONTACT, -2.0 + 0.08 * t, -2.0 + 0.08 * CONTACT), np.zeros_like(t)])
    hit = np.column_stack([np.where(t < CONTACT, mover[CONTACT, 0] + 2 * SIZE, mover[CONTACT, 0] + 2 * SIZE + 0.08 * (t - CONTACT)),
                           np.zeros_like(t)])
    return mover, hit


def _crossed(first: np.ndarray, second: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    after = FRAMES >= CONTACT
    return np.where(after[:, None], second, first), np.where(after[:, None], first, second)


def _owner_after(tracks: list[LiftedTrack], path: np.ndarray) -> int:
    """Id of the track whose samples after the merge follow ``path``."""
    late = FRAMES > MERGED[-1]
    errors = {t.id: float(np.median(np.linalg.norm(t.positions[np.isin(t.frames, FRAMES[late]), :2] - path[late], axis=1)))
              for t in tracks}
    track_id = min(errors, key=errors.get)
    assert errors[track_id] < 0.02
    return track_id


def test_identities_crossed_at_a_head_on_hit_are_given_back():
    mover, hit = _head_on()
    a_path, b_path = _crossed(mover, hit)  # what the frame-to-frame tracker hands over
    tracks = [_track(0, a_path, 1), _track(1, b_path, 2)]
    untangled = _untangle_contacts(tracks, SIZE, {0: RED, 1: RED})
    assert _owner_after(untangled, mover) == 0
    assert _owner_after(untangled, hit) == 1
    # before the contact nothing moved
    for before, after in zip(tracks, untangled):
        early = FRAMES < CONTACT
        assert np.array_equal(before.positions[early], after.positions[np.isin(after.frames, FRAMES[early])])


def test_tracks_that_kept_their_objects_through_the_hit_are_left_alone():
    mover, hit = _head_on()
    tracks = [_track(0, mover, 1), _track(1, hit, 2)]
    untangled = _untangle_contacts(tracks, SIZE, {0: RED, 1: RED})
    for before, after in zip(tracks, untangled):
        assert np.array_equal(before.frames, after.frames) and np.array_equal(before.positions, after.positions)


def test_objects_that_meet_head_on_and_bounce_back_keep_their_tracks():
    """Fresh seed 41414, scene 84: a yellow cylinder and a yellow cube meet head-on (0.075 m a frame each)
    and bounce back slowly, one segment in the image from the frame before the hit to 11 after. Each one's
    motion before, carried on straight to the middle of those frames, lands where the other is after,
    so the crossed pairing joins the motions better; but it would have the two pass through each other."""
    t = FRAMES.astype(float)
    since = t - CONTACT
    left = np.column_stack([-1.0 - SIZE + np.where(since < 0, 0.075, -0.015) * since, np.zeros_like(t)])
    right = np.column_stack([-1.0 + SIZE - np.where(since < 0, 0.075, -0.015) * since, np.zeros_like(t)])
    one_segment = range(CONTACT - 1, CONTACT + 12)
    tracks = [_track(0, left, 5, one_segment), _track(1, right, 6, one_segment)]
    untangled = _untangle_contacts(tracks, SIZE, {0: RED, 1: RED})
    assert _owner_after(untangled, left) == 0 and _owner_after(untangled, right) == 1


def test_objects_told_apart_by_colour_are_left_to_the_tracker():
    mover, hit = _head_on()
    a_path, b_path = _crossed(mover, hit)
    blue = np.array([0.2, 0.25, 0.55, 0.0])
    tracks = [_track(0, a_path, 1), _track(1, b_path, 2)]
    untangled = _untangle_contacts(tracks, SIZE, {0: RED, 1: blue})
    assert _owner_after(untangled, hit) == 0  # unchanged: a colour change at a contact is the tracker's call


def test_two_objects_passing_close_keep_their_tracks():
    """A near miss (centres 0.5 m apart as they pass at frame 28.6, one segment in the image
    meanwhile), both moving on: constant velocity joins each to itself."""
    t = FRAMES.astype(float)
    first = np.column_stack([-2.0 + 0.07 * t, np.full_like(t, -0.25)])
    second = np.column_stack([2.0 - 0.07 * t, np.full_like(t, 0.25)])
    passing = range(26, 32)
    tracks = [_track(0, first, 3, passing), _track(1, second, 4, passing)]
    untangled = _untangle_contacts(tracks, SIZE, {0: RED, 1: RED})
    assert _owner_after(untangled, first) == 0 and _owner_after(untangled, second) == 1


def _piece(track_id: int, frames: np.ndarray, path, color: str = "red", weight: float = 1.0) -> LiftedTrack:
    xy = np.array([path(f) for f in frames])
    positions = np.column_stack([xy, np.full(len(frames), SIZE)])
    attributes = Attributes(color, "cylinder", "rubber", 1.0, shape_score=0.9)
    return LiftedTrack(track_id, attributes, frames.astype(np.int64), positions, np.full(len(frames), np.nan),
                       np.ones(len(frames), bool), np.full(len(frames), weight))


def _turning(frame: float) -> np.ndarray:
    """An object sliding along x that a hit at frame 32 turns along y (m)."""
    return np.array([0.05 * frame, 0.0]) if frame <= 32 else np.array([1.6, 0.1 * (frame - 32)])


def test_a_piece_seen_with_the_object_before_and_after_a_turn_makes_one_track():
    """The object is one tracklet before the hit (0-32) and another after (39-127); a piece of it
    (3-39, the dark half of a metal cylinder) overlaps the first on 30 frames and the second on one.
    The turn stops the motion link; the piece shows the two are one object (main joined the piece
    to the second by its one frame and left the first as a second track)."""
    from perception.pipeline import _associate

    before = _piece(0, np.arange(0, 33), _turning)
    piece = _piece(1, np.arange(3, 40), lambda f: _turning(f) + np.array([0.06, 0.0]), weight=0.6)
    after = _piece(2, np.arange(39, 128), _turning)
    tracks = _associate([before, piece, after], SIZE)
    assert len(tracks) == 1
    assert tracks[0].frames[0] == 0 and tracks[0].frames[-1] == 127


def test_a_piece_over_two_objects_side_by_side_does_not_merge_them():
    """A tracklet of two touching objects' shared segment lies within one size of each on most of
    its frames in common with it (the left one is lost after frame 24); the two objects are seen
    apart at the same time, so they stay two."""
    from perception.pipeline import _associate

    left = _piece(0, np.arange(0, 25), lambda f: np.array([0.0, 0.0]))
    right = _piece(1, np.arange(0, 60), lambda f: np.array([0.45, 0.0]))
    blob = _piece(2, np.arange(20, 31), lambda f: np.array([0.1 if f < 25 else 0.35, 0.0]), weight=0.3)
    tracks = _associate([left, right, blob], SIZE)
    assert len(tracks) == 2
