"""bench_perception counts the segments the tracker split between tracks by the true objects they hold."""

import numpy as np

from bench.bench_perception import split_segments
from perception.types import Detection, TrackState
from world.camera import look_at_camera, project

CAMERA = look_at_camera((0.0, -7.0, 6.0), (0.0, 0.0, 0.0))
SIZE = 0.2


def _halves(frame: int, around: tuple[float, float], radius_px: float) -> tuple[Detection, Detection]:
    """A disc segment around the pixel of a centre at ground ``around``, split at its middle column into two pieces."""
    u, v = project(CAMERA, np.array([around[0], around[1], SIZE]))
    ys, xs = np.mgrid[0:CAMERA.height, 0:CAMERA.width]
    inside = (xs - u) ** 2 + (ys - v) ** 2 <= radius_px ** 2
    left, right = inside & (xs < u), inside & (xs >= u)
    return tuple(Detection(frame, *(a.astype(np.int32) for a in np.nonzero(half)), 1, False, 7, split=True) for half in (left, right))


def _tracks(pieces: list[tuple[Detection, Detection]]) -> list[TrackState]:
    first, second = TrackState(id=0, hue_label=1), TrackState(id=1, hue_label=1)
    for a, b in pieces:
        first.detections[a.frame], second.detections[b.frame] = a, b
    return [first, second]


def test_a_split_segment_is_counted_by_the_true_centres_it_holds():
    tracks = _tracks([_halves(0, (0.0, 0.0), 14.0), _halves(1, (0.0, 0.0), 14.0)])
    one_object = {5: {0: np.array([0.0, 0.0, SIZE]), 1: np.array([0.0, 0.0, SIZE])}}
    assert split_segments(tracks, CAMERA, one_object) == (2, 0)
    # a second object whose centre is among the segment's pixels on frame 1 only (on frame 0 it is 1 m away)
    two = {**one_object, 6: {0: np.array([1.0, 0.0, SIZE]), 1: np.array([0.15, 0.0, SIZE])}}
    assert split_segments(tracks, CAMERA, two) == (1, 1)


def test_segments_not_split_are_not_counted():
    whole = TrackState(id=0, hue_label=1)
    (a, b) = _halves(0, (0.0, 0.0), 14.0)
    whole.detections[0] = Detection(0, np.concatenate([a.ys, b.ys]), np.concatenate([a.xs, b.xs]), 1, False, 7)
    assert split_segments([whole], CAMERA, {5: {0: np.array([0.0, 0.0, SIZE])}}) == (0, 0)
