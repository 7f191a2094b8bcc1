"""One object = one segment = one track (perception.segment.merge_object_pieces, pipeline._associate's
explained pieces) and attributes of joined tracks decided over all their frames.

Scenes are painted in the test: primitives ray-cast with a fixture's camera over a plain floor, a metal
object drawn as two palette colours (a dark body and a bright highlight part, as a renderer's specular
reflection splits it) and two touching objects of different colours.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from perception.background import FLOOR, OBJECT, Background
from perception.geometry import primitive_window, ray_depths, silhouette
from perception.pipeline import _explained_by, _merged_state, _pooled_shape_scores, _redecide_attributes, perceive_frames
from perception.segment import merge_object_pieces, segment_frame
from perception.types import Attributes, Detection, FrameSegments, LiftedTrack, TrackState
from world.camera import backproject_to_height
from world.io import load_camera
from world.types import CLEVR_PALETTE_RGB

CAMERA = load_camera(Path(__file__).resolve().parents[1] / "data" / "synth" / "ground_truth" / "scene_00000.json")
SIZE = 0.2
FLOOR_RGB = (150, 150, 150)
BODY_RGB = (20, 35, 110)  # dark blue body of a metal object
HIGHLIGHT_RGB = (110, 225, 235)  # its bright reflection, read as cyan by the palette


def _floor_point(u: float, v: float) -> np.ndarray:
    """(3,) centre of an object whose centre projects near pixel (u, v)."""
    return backproject_to_height(CAMERA, np.array([[u, v]]), SIZE)[0]


def _paint(frame: np.ndarray, depth: np.ndarray, kind: str, centre: np.ndarray, colour_of_rows) -> None:
    """Z-buffered paint of one primitive; colour_of_rows(rows (h, w) relative to the silhouette's middle) -> (h, w, 3)."""
    window = primitive_window(CAMERA, kind, centre, SIZE)
    t = ray_depths(CAMERA, kind, centre, SIZE, 0.0, window)
    region = depth[window.top:window.bottom, window.left:window.right]
    nearer = t < region
    region[nearer] = t[nearer]
    rows = np.mgrid[window.top:window.bottom, window.left:window.right][0].astype(float)
    middle = rows[np.isfinite(t)].mean()
    colours = colour_of_rows(rows - middle)
    frame[window.top:window.bottom, window.left:window.right][nearer] = colours[nearer]


def _split_metal(relative_rows: np.ndarray) -> np.ndarray:
    """Upper part a bright highlight, the rest a dark body: two palette colours, each a big piece."""
    out = np.empty(relative_rows.shape + (3,), np.uint8)
    out[:] = BODY_RGB
    out[relative_rows < -4] = HIGHLIGHT_RGB
    return out


def _plain(rgb):
    return lambda rows: np.broadcast_to(np.asarray(rgb, np.uint8), rows.shape + (3,)).copy()


def _scene(num_frames: int = 14) -> np.ndarray:
    """(F, H, W, 3) frames: a split metal cylinder moving right; a red sphere touching a green cube, at rest."""
    frames = np.empty((num_frames, CAMERA.height, CAMERA.width, 3), np.uint8)
    start = _floor_point(0.3 * CAMERA.width, 0.45 * CAMERA.height)
    sphere = _floor_point(0.65 * CAMERA.width, 0.6 * CAMERA.height)
    cube = sphere + np.array([0.0, 2.0 * SIZE + 0.01, 0.0])  # touching side by side
    for f in range(num_frames):
        frames[f] = FLOOR_RGB
        depth = np.full((CAMERA.height, CAMERA.width), np.inf)
        _paint(frames[f], depth, "cylinder", start + np.array([0.03 * f, 0.0, 0.0]), _split_metal)
        _paint(frames[f], depth, "sphere", sphere, _plain(CLEVR_PALETTE_RGB["red"]))
        _paint(frames[f], depth, "cube", cube, _plain(CLEVR_PALETTE_RGB["green"]))
    return frames


def _flat_background() -> Background:
    image = np.empty((CAMERA.height, CAMERA.width, 3), np.float32)
    image[:] = FLOOR_RGB
    return Background(image=image, floor_fit=image.copy(), static=np.zeros((CAMERA.height, CAMERA.width), bool))


@pytest.fixture(scope="module")
def frames() -> np.ndarray:
    return _scene()


def test_a_metal_object_split_into_two_colours_becomes_one_segment_and_touching_objects_stay_two(frames):
    raw = segment_frame(frames[0], _flat_background(), 0)
    labels = sorted(d.hue_label for d in raw.detections)
    assert len(raw.detections) == 4, labels  # the split the merge must undo: body + highlight, sphere, cube
    merged = merge_object_pieces(raw, CAMERA, SIZE)
    assert len(merged.detections) == 3
    colours = {d.hue_label for d in merged.detections}
    assert len(colours) == 3  # the red sphere and the green cube touching were not merged


def test_the_split_metal_object_gives_one_track_and_touching_objects_two(frames):
    observations, _ = perceive_frames(frames, CAMERA, object_size=SIZE)
    assert len(observations.objects) == 3
    moving = [t for t in observations.objects if np.ptp(t.positions[:, 0]) > 0.2]
    assert len(moving) == 1 and len(moving[0].frames) == len(frames)
    assert sorted(t.color for t in observations.objects if t is not moving[0]) == ["green", "red"]


def _detection(frame: int, top: int, left: int, side: int = 12) -> Detection:
    ys, xs = np.mgrid[top:top + side, left:left + side]
    return Detection(frame, ys.ravel().astype(np.int32), xs.ravel().astype(np.int32), 0, False, 1)


def test_a_joined_track_redecides_colour_and_shape_over_all_its_frames():
    """The best-fitting tracklet read the object brown (its 40 frames are brownish) and a sphere on 2 frames;
    over all 128 frames the object is mostly red and the pooled overlaps favour a cube."""
    num_frames, height, width = 128, 40, 40
    frames = np.empty((num_frames, height, width, 3), np.uint8)
    frames[:] = FLOOR_RGB
    frames[:40, 10:22, 10:22] = CLEVR_PALETTE_RGB["brown"]
    frames[40:, 10:22, 10:22] = CLEVR_PALETTE_RGB["red"]
    labels = np.full((height, width), FLOOR, np.uint8)
    labels[10:22, 10:22] = OBJECT
    segments = [FrameSegments(f, labels, (_detection(f, 10, 10),)) for f in range(num_frames)]

    def tracklet(track_id, frame_range, color, shape, score):
        frame_ids = np.arange(*frame_range)
        positions = np.tile([0.0, 0.0, SIZE], (len(frame_ids), 1))
        return LiftedTrack(track_id, Attributes(color, shape, "rubber", 1.0, shape_score=score), frame_ids, positions,
                           np.full(len(frame_ids), np.nan), np.ones(len(frame_ids), bool), np.ones(len(frame_ids)))

    source = tracklet(0, (0, 40), "brown", "sphere", 0.95)
    later = tracklet(1, (40, 128), "red", "cube", 0.9)
    states = {t.id: TrackState(t.id, 0, {int(f): segments[int(f)].detections[0] for f in t.frames}) for t in (source, later)}
    scores_of = {0: {"sphere": [0.9, 0.9], "cube": [0.6, 0.6], "cylinder": [0.5, 0.5]},
                 1: {"sphere": [0.7] * 6, "cube": [0.9] * 6, "cylinder": [0.6] * 6}}
    group = [source, later]
    attributes = _redecide_attributes(_merged_state(group, states), _pooled_shape_scores(group, states, scores_of),
                                      frames, segments)
    assert (attributes.color, attributes.shape) == ("red", "cube")
    # the probabilities grounding uses are re-decided with the values (not the first tracklet's, stale)
    assert max(attributes.color_probabilities, key=attributes.color_probabilities.get) == "red"
    assert max(attributes.shape_probabilities, key=attributes.shape_probabilities.get) == "cube"
    assert attributes.shape_score == pytest.approx((2 * 0.6 + 6 * 0.9) / 8)


def test_a_piece_inside_another_tracks_primitive_is_explained_by_it_but_a_neighbour_is_not():
    centre = _floor_point(0.5 * CAMERA.width, 0.5 * CAMERA.height)
    frame_ids = np.arange(10)
    anchor = LiftedTrack(0, Attributes("blue", "cylinder", "metal", 1.0, shape_score=0.9), frame_ids,
                         np.tile(centre, (10, 1)), np.full(10, np.nan), np.ones(10, bool), np.ones(10))

    def state(track_id, at, upper_only):
        window, sil = silhouette(CAMERA, "cylinder", at, SIZE)
        ys, xs = np.nonzero(sil)
        if upper_only:  # the highlight part: the upper third of the silhouette
            keep = ys < np.percentile(ys, 33)
            ys, xs = ys[keep], xs[keep]
        det = Detection(0, (ys + window.top).astype(np.int32), (xs + window.left).astype(np.int32), 5, False, 1)
        return TrackState(track_id, 5, {int(f): replace(det, frame=int(f)) for f in frame_ids})

    assert _explained_by(CAMERA, SIZE, state(1, centre, upper_only=True), anchor)
    neighbour = centre + np.array([2.0 * SIZE + 0.01, 0.0, 0.0])
    assert not _explained_by(CAMERA, SIZE, state(2, neighbour, upper_only=False), anchor)
    assert not _explained_by(CAMERA, SIZE, state(3, centre, upper_only=False), anchor)  # a whole object is no piece
