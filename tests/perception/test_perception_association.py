"""Global association over tracklets (perception.pipeline._associate) on hand-made tracklets."""

from __future__ import annotations

import numpy as np

from perception.pipeline import _associate
from perception.types import Attributes, LiftedTrack

SIZE = 0.2


def _tracklet(track_id: int, frames: range, start_xy: tuple[float, float], velocity_xy: tuple[float, float],
              color: str = "red", shape: str = "sphere", score: float = 0.9) -> LiftedTrack:
    frames = np.asarray(list(frames), dtype=np.int64)
    t = (frames - frames[0])[:, None]
    xy = np.asarray(start_xy) + t * np.asarray(velocity_xy)
    positions = np.column_stack([xy, np.full(len(frames), SIZE)])
    return LiftedTrack(track_id, Attributes(color, shape, "rubber", 1.0, shape_score=score), frames, positions,
                       np.full(len(frames), np.nan), np.ones(len(frames), bool), np.ones(len(frames)))


def test_a_fragment_after_an_occlusion_continues_its_track():
    before = _tracklet(0, range(0, 40), (0.0, 0.0), (0.02, 0.0))
    after = _tracklet(1, range(52, 128), (0.02 * 52, 0.0), (0.02, 0.0))
    (joined,) = _associate([before, after], SIZE)
    assert joined.frames[0] == 0 and joined.frames[-1] == 127 and len(joined.frames) == 40 + 76


def test_other_colour_or_far_away_or_long_gap_is_another_object():
    before = _tracklet(0, range(0, 40), (0.0, 0.0), (0.02, 0.0))
    other_colour = _tracklet(1, range(45, 128), (0.02 * 45, 0.1), (0.02, 0.03), color="blue")
    far = _tracklet(2, range(45, 128), (3.0, 2.0), (0.0, 0.0))
    much_later = _tracklet(3, range(100, 128), (0.02 * 39 + 0.1, 0.0), (0.0, 0.0))  # where it stopped, 60 frames on
    assert len(_associate([before, other_colour, far, much_later], SIZE)) == 4


def test_two_tracklets_on_one_object_become_one_with_all_frames():
    whole = _tracklet(0, range(0, 128), (0.0, 0.0), (0.01, 0.0))
    duplicate = _tracklet(1, range(20, 60), (0.2 + 0.03, 0.01), (0.01, 0.0), score=0.5)
    (merged,) = _associate([duplicate, whole], SIZE)
    assert len(merged.frames) == 128 and np.allclose(merged.positions[:, 0], whole.positions[:, 0])


def test_each_tracklet_continues_at_most_one_other():
    a = _tracklet(0, range(0, 30), (0.0, 0.0), (0.02, 0.0))
    b = _tracklet(1, range(35, 70), (0.02 * 35, 0.0), (0.02, 0.0))
    c = _tracklet(2, range(75, 128), (0.02 * 75, 0.0), (0.02, 0.0))
    (chain,) = _associate([c, a, b], SIZE)
    assert len(chain.frames) == 30 + 35 + 53 and np.all(np.diff(chain.frames) > 0)
