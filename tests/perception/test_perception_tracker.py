"""HungarianTracker on hand-made detections (discs of pixels at projected ground positions)."""

from __future__ import annotations

import numpy as np

from perception.track import HungarianTracker
from perception.types import Detection, FrameSegments
from world.camera import look_at_camera, project
from world.types import COLORS

SIZE = 0.2
CAMERA = look_at_camera((0.0, -7.0, 6.0), (0.0, 0.0, 0.0))
RED, BROWN, YELLOW, BLUE = COLORS.index("red"), COLORS.index("brown"), COLORS.index("yellow"), COLORS.index("blue")


def _disc(frame: int, xy: tuple[float, float], hue: int, radius_px: float) -> tuple[np.ndarray, np.ndarray]:
    u, v = project(CAMERA, np.array([xy[0], xy[1], SIZE]))
    ys, xs = np.mgrid[0:CAMERA.height, 0:CAMERA.width]
    inside = (xs - u) ** 2 + (ys - v) ** 2 <= radius_px ** 2
    return ys[inside].astype(np.int32), xs[inside].astype(np.int32)


def _frames(objects_per_frame: list[list[tuple]]) -> list[FrameSegments]:
    """Per frame a list of (ground xy, hue label[, radius px]); discs of one hue that overlap become one segment."""
    segments = []
    for frame, objects in enumerate(objects_per_frame):
        by_hue: dict[int, list[tuple[np.ndarray, np.ndarray]]] = {}
        for xy, hue, *radius in objects:
            by_hue.setdefault(hue, []).append(_disc(frame, xy, hue, radius[0] if radius else 9.0))
        detections = []
        for component, (hue, discs) in enumerate(by_hue.items(), start=1):
            mask = np.zeros((CAMERA.height, CAMERA.width), bool)
            pieces = []
            for ys, xs in discs:
                piece = np.zeros_like(mask)
                piece[ys, xs] = True
                pieces.append(piece)
            merged = [pieces[0]]
            for piece in pieces[1:]:  # overlapping discs of one hue are one segment
                if any((piece & m).any() for m in merged):
                    merged = [m | piece if (piece & m).any() else m for m in merged]
                else:
                    merged.append(piece)
            for k, m in enumerate(merged):
                ys, xs = np.nonzero(m)
                detections.append(Detection(frame, ys.astype(np.int32), xs.astype(np.int32), hue, False, 10 * component + k))
        segments.append(FrameSegments(frame, np.zeros((CAMERA.height, CAMERA.width), np.uint8), tuple(detections)))
    return segments


def test_a_lost_track_does_not_take_a_detection_of_another_colour():
    frames = [[((-1.0 + 0.03 * f, 0.0), RED)] for f in range(10)] + [[] for _ in range(10)]
    frames += [[((-1.0 + 0.03 * f, 1.0), BROWN)] for f in range(20, 30)]  # inside the widened gate, 1 m off the prediction
    tracks = HungarianTracker(SIZE).track(_frames(frames), CAMERA)
    assert len(tracks) == 2 and sorted(len(t.detections) for t in tracks) == [10, 10]


def test_a_track_lost_long_does_not_take_another_colour_entering_where_it_was_lost():
    # a red object lost at frame 10 (stopped behind something); 20 frames later a blue one enters 0.2 m from there
    frames = [[((-1.0 + 0.03 * f, 0.0), RED)] for f in range(10)] + [[] for _ in range(20)]
    frames += [[((-0.73 + 0.03 * (f - 30), 0.2), BLUE)] for f in range(30, 40)]
    tracks = HungarianTracker(SIZE).track(_frames(frames), CAMERA)
    assert len(tracks) == 2 and sorted(len(t.detections) for t in tracks) == [10, 10]


def test_a_colour_reread_from_one_frame_to_the_next_stays_on_its_track():
    frames = [[((-1.0 + 0.03 * f, 0.0), RED if f < 10 else BROWN)] for f in range(20)]
    (track,) = HungarianTracker(SIZE).track(_frames(frames), CAMERA)
    assert len(track.detections) == 20


def test_a_small_object_merged_into_a_large_same_coloured_one_keeps_its_track():
    resting = (0.0, 0.0)  # a small ball ...
    frames = []
    for f in range(40):
        arriving = (-1.5 + 0.06 * min(f, 20), 0.1)  # ... that a large cube of its colour stops against from frame 20 on
        frames.append([(resting, YELLOW, 7.0), (arriving, YELLOW, 14.0)])
    tracks = HungarianTracker(SIZE).track(_frames(frames), CAMERA)
    assert len(tracks) == 2
    for track in tracks:
        assert len(track.detections) == 40, f"track {track.id} lost frames {sorted(set(range(40)) - set(track.detections))}"
    still = min(tracks, key=lambda t: np.ptp([g[0] for g in t.ground.values()]))
    assert max(np.linalg.norm(g - np.array(resting)) for g in still.ground.values()) < 0.2
