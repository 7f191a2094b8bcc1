"""perceive(): video + camera -> Observations (tracked objects on the support plane).

Stages behind small interfaces (perception.types): a Segmenter (classical
background model + colour split), a Tracker (Hungarian on the ground plane)
and a Lifter (projected-primitive fit, which also decides shape, colour and
material from the most isolated frames). A user with learned models can pass
their own implementations to :func:`perceive_frames`.
"""

from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from tqdm import tqdm

from perception.attributes import color_of, material_of
from perception.geometry import primitive_window, ray_depths, silhouette
from perception.lift import Fit, fit_cube, fit_detection, fit_primitive, initial_centre
from perception.segment import MIN_SEGMENT_AREA, ClassicalSegmenter
from perception.track import HungarianTracker
from perception.types import Attributes, FrameSegments, LiftedTrack, Lifter, Segmenter, Tracker, TrackState
from perception.video import read_video
from world.camera import backproject_to_height, footprint_visible
from world.observations import DEFAULT_OBJECT_SIZE, ObjectTrack, Observations, default_shape
from world.types import SHAPE_KINDS, Camera

MAX_ATTRIBUTE_FRAMES = 6  # isolated frames used to decide shape (a fit per frame and primitive)
MAX_APPEARANCE_FRAMES = 16  # isolated frames used to decide colour / material (cheap per frame)
MIN_SHAPE_SCORE = 0.4  # mean silhouette overlap below which a track is not an object

# Per-frame confidence: lower where the object is cut by the border, touches
# another object, or was carved out of a shared segment.
WEIGHT_BORDER = 0.5
WEIGHT_TOUCHING = 0.6
WEIGHT_SPLIT = 0.3
WEIGHT_EXTRAPOLATED = 0.05  # frames added through the border at constant velocity (no evidence of their own)
EXTRAPOLATION_BASE = 4  # frames at a track's end whose motion is extrapolated through the border
MAX_EXTRAPOLATED_FRAMES = 10
MAX_LINK_GAP = 40  # frames: longest gap (occlusion, lost detection) across which two tracklets are joined
LINK_GATE = 0.45  # m: largest distance between a tracklet's predicted position and the next one's start ...
LINK_GATE_PER_FRAME = 0.02  # ... plus this per frame of gap (the prediction is held after 5 frames)


def _isolated_frames(track: TrackState, segments: list[FrameSegments]) -> list[int]:
    """Frames where the track's segment is whole: alone in its component, not split, not at the border."""
    areas = np.array([d.area for d in track.detections.values()])
    typical = float(np.median(areas))
    chosen = []
    for frame, det in sorted(track.detections.items()):
        alone = sum(1 for d in segments[frame].detections if d.component == det.component) == 1
        if alone and not det.split and not det.touches_border and det.area >= 0.6 * typical:
            chosen.append(frame)
    return chosen


def _spread(frames: list[int], count: int) -> list[int]:
    if len(frames) <= count:
        return frames
    return [frames[int(round(k))] for k in np.linspace(0, len(frames) - 1, count)]


class PrimitiveLifter:
    """Projected-primitive fit with the known object size (no learned weights)."""

    def __init__(self, object_size: float = DEFAULT_OBJECT_SIZE) -> None:
        self.size = object_size

    def decide_shape(self, camera: Camera, track: TrackState, segments: list[FrameSegments], frames_used: list[int]) -> tuple[str, float]:
        scores = {kind: [] for kind in SHAPE_KINDS}
        for frame in frames_used:
            det = track.detections[frame]
            labels = segments[frame].labels
            start = initial_centre(camera, det, self.size)
            scores["sphere"].append(fit_primitive(camera, "sphere", start, self.size, 0.0, labels, det).score)
            scores["cylinder"].append(fit_primitive(camera, "cylinder", start, self.size, 0.0, labels, det).score)
            scores["cube"].append(fit_cube(camera, start, self.size, labels, det).score)
        means = {kind: float(np.mean(v)) if v else 0.0 for kind, v in scores.items()}
        ranked = sorted(means, key=means.get, reverse=True)
        return ranked[0], means[ranked[0]] - means[ranked[1]], means[ranked[0]]

    def lift(self, frames: np.ndarray, segments: list[FrameSegments], tracks: list[TrackState],
             camera: Camera, *, progress: bool = False) -> list[LiftedTrack]:
        iterator = tracks
        if progress:
            iterator = tqdm(tracks, desc="lift", unit="object")
        lifted = []
        for track in iterator:
            isolated = _isolated_frames(track, segments)
            basis = _spread(isolated, MAX_ATTRIBUTE_FRAMES) or _spread(sorted(track.detections), MAX_ATTRIBUTE_FRAMES)
            kind, margin, shape_score = self.decide_shape(camera, track, segments, basis)
            if shape_score < MIN_SHAPE_SCORE:  # no primitive of the known size explains it: a fragment, not an object
                continue
            appearance = _spread(isolated, MAX_APPEARANCE_FRAMES) or _spread(sorted(track.detections), MAX_APPEARANCE_FRAMES)
            detections = [track.detections[f] for f in appearance]
            color = color_of(detections, frames)
            material, metal_probability = material_of(detections, frames, segments, color, kind)
            attributes = Attributes(color=color, shape=kind, material=material, confidence=float(np.clip(margin * 5, 0, 1)),
                                    metal_probability=metal_probability, shape_score=shape_score)
            frame_ids, positions, yaws, weights = [], [], [], []
            previous: Fit | None = None
            for frame, det in sorted(track.detections.items()):
                fit = fit_detection(camera, kind, det, segments[frame].labels, self.size, previous)
                previous = fit
                weight = float(np.clip(fit.score / 0.7, 0.0, 1.0))
                if det.touches_border:
                    weight *= WEIGHT_BORDER
                if det.split or frame in track.merged:
                    weight *= WEIGHT_SPLIT
                elif sum(1 for d in segments[frame].detections if d.component == det.component) > 1:
                    weight *= WEIGHT_TOUCHING
                frame_ids.append(frame)
                positions.append(fit.centre)
                yaws.append(fit.yaw if kind == "cube" else np.nan)
                weights.append(weight)
            frame_ids, positions, yaws, weights = _extend_through_border(
                camera, kind, self.size, frames.shape[0], track, np.asarray(frame_ids, dtype=np.int64),
                np.asarray(positions), np.asarray(yaws), np.asarray(weights))
            visible = footprint_visible(camera, default_shape(kind, self.size), positions, np.nan_to_num(yaws))
            lifted.append(LiftedTrack(track.id, attributes, frame_ids, positions, yaws, visible, weights))
        return _renumber(_associate(lifted, self.size))


def _extend_through_border(camera: Camera, kind: str, size: float, num_frames: int, track: TrackState,
                           frames: np.ndarray, positions: np.ndarray, yaws: np.ndarray, weights: np.ndarray):
    """Extend a track that enters (leaves) through the image border backwards (forwards) at constant
    velocity over the frames where its footprint is already (still) in view but less of its
    silhouette than MIN_SEGMENT_AREA is inside the image (too little to be segmented), so that entry and exit frames follow the same visibility rule as the
    truth (world.camera.footprint_visible). Added frames get weight WEIGHT_EXTRAPOLATED.

    frames (T,), positions (T, 3) m, yaws (T,), weights (T,) -> the same, extended.
    """
    shape = default_shape(kind, size)
    ends = []
    for first, step in ((True, -1), (False, 1)):
        k = 0 if first else len(frames) - 1
        if not track.detections[int(frames[k])].touches_border or len(frames) < EXTRAPOLATION_BASE + 1:
            ends.append(([], []))
            continue
        base = positions[:EXTRAPOLATION_BASE + 1] if first else positions[-EXTRAPOLATION_BASE - 1:]
        base_frames = frames[:EXTRAPOLATION_BASE + 1] if first else frames[-EXTRAPOLATION_BASE - 1:]
        velocity = (base[-1] - base[0]) / max(int(base_frames[-1] - base_frames[0]), 1)  # m per frame
        added_frames, added_positions = [], []
        for n in range(1, MAX_EXTRAPOLATED_FRAMES + 1):
            frame = int(frames[k]) + step * n
            if not 0 <= frame < num_frames:
                break
            position = positions[k] + velocity * step * n
            if not footprint_visible(camera, shape, position[None], np.zeros(1))[0]:
                break
            if silhouette(camera, kind, position, size)[1].sum() >= MIN_SEGMENT_AREA:
                break  # this much of it in view would have been segmented: it was not there
            added_frames.append(frame)
            added_positions.append(position)
        ends.append((added_frames, added_positions))
    (before, before_pos), (after, after_pos) = ends
    if not before and not after:
        return frames, positions, yaws, weights
    # cube yaw is held at the nearest fitted value (NaN for other shapes stays NaN)
    return (np.concatenate([np.asarray(before[::-1], np.int64), frames, np.asarray(after, np.int64)]),
            np.concatenate([np.asarray(before_pos[::-1]).reshape(-1, 3), positions, np.asarray(after_pos).reshape(-1, 3)]),
            np.concatenate([np.full(len(before), yaws[0]), yaws, np.full(len(after), yaws[-1])]),
            np.concatenate([np.full(len(before), WEIGHT_EXTRAPOLATED), weights, np.full(len(after), WEIGHT_EXTRAPOLATED)]))


def _union(keep: LiftedTrack, other: LiftedTrack) -> LiftedTrack:
    """One track from two tracklets of one object: all frames of both; on a frame both hold, the
    sample with the larger weight; attributes of ``keep`` (the better supported tracklet)."""
    frames = np.union1d(keep.frames, other.frames)
    rows = {}
    for track in (other, keep):  # keep's samples win ties
        for k, frame in enumerate(track.frames):
            current = rows.get(int(frame))
            if current is None or track.weights[k] >= current[0].weights[current[1]]:
                rows[int(frame)] = (track, k)
    pick = [rows[int(f)] for f in frames]
    return replace(keep, frames=frames.astype(np.int64),
                   positions=np.array([t.positions[k] for t, k in pick]), yaw=np.array([t.yaw[k] for t, k in pick]),
                   visible=np.array([t.visible[k] for t, k in pick]), weights=np.array([t.weights[k] for t, k in pick]))


def _same_look(a: LiftedTrack, b: LiftedTrack) -> bool:
    return a.attributes.color == b.attributes.color and a.attributes.shape == b.attributes.shape


def _link_cost(earlier: LiftedTrack, later: LiftedTrack, size: float) -> float:
    """Ground distance (m) between ``earlier``'s constant-velocity prediction and ``later``'s first
    position, for a tracklet that starts after the other ends; inf when they cannot be one object."""
    gap = int(later.frames[0] - earlier.frames[-1])
    if not 0 < gap <= MAX_LINK_GAP or not _same_look(earlier, later):
        return np.inf
    base = earlier.positions[-EXTRAPOLATION_BASE - 1:]
    span = max(int(earlier.frames[-1] - earlier.frames[-min(len(earlier.frames), EXTRAPOLATION_BASE + 1)]), 1)
    velocity = (base[-1] - base[0]) / span
    predicted = earlier.positions[-1] + velocity * min(gap, 5)
    distance = float(np.linalg.norm(predicted[:2] - later.positions[0, :2]))
    return distance if distance <= LINK_GATE + LINK_GATE_PER_FRAME * gap else np.inf


def _associate(lifted: list[LiftedTrack], size: float) -> list[LiftedTrack]:
    """Global association of tracklets over the whole video.

    1. Duplicates: two tracklets whose centres stay closer than one object size on most common
       frames are one object (two solid objects cannot be that close): the better supported one
       takes the other's frames.
    2. Fragments: a tracklet that starts after another of the same colour and shape ended, near
       where that one was heading, continues it (an occlusion, a merge with a touching object, a
       lost detection). Links are made cheapest first, each tracklet continuing at most one.
    """
    order = sorted(lifted, key=lambda t: (t.attributes.shape_score * len(t.frames)), reverse=True)
    kept: list[LiftedTrack] = []
    for track in order:
        for index, other in enumerate(kept):
            common, ia, ib = np.intersect1d(track.frames, other.frames, return_indices=True)
            if common.size == 0:
                continue
            gaps = np.linalg.norm(track.positions[ia, :2] - other.positions[ib, :2], axis=1)
            if np.mean(gaps < size) > 0.5:
                kept[index] = _union(other, track) if _same_look(track, other) else other
                break
        else:
            kept.append(track)
    while True:
        costs = [(_link_cost(a, b, size), i, j) for i, a in enumerate(kept) for j, b in enumerate(kept) if i != j]
        finite = [c for c in costs if np.isfinite(c[0])]
        if not finite:
            return kept
        _, i, j = min(finite)
        a, b = kept[i], kept[j]
        better, worse = (a, b) if a.attributes.shape_score * len(a.frames) >= b.attributes.shape_score * len(b.frames) else (b, a)
        kept = [t for k, t in enumerate(kept) if k not in (i, j)] + [_union(better, worse)]


def _renumber(lifted: list[LiftedTrack]) -> list[LiftedTrack]:
    """Ids 0..K-1 in order of first appearance."""
    ordered = sorted(lifted, key=lambda t: (int(t.frames[0]), t.id))
    return [replace(t, id=k) for k, t in enumerate(ordered)]


MIN_CONTRAST = 4.0  # grey levels between the 1st and 99th percentile below which a frame is blank (black, one colour)
MOVING_PIXELS = 60  # px: a frame differing from the video's median in fewer pixels than this shows no motion
MOVING_DIFFERENCE = 12  # grey levels: a pixel this far from the video's median changed


def check_frames(frames: np.ndarray, camera: Camera) -> None:
    """One clear ValueError for input perception cannot work on (before any heavy work).

    frames: (F, H, W, 3) uint8. Checks: the resolution is the camera's, the
    camera looks down at the floor plane z = 0, the video is not blank, and
    something moves in it.
    """
    height, width = frames.shape[1:3]
    if (width, height) != (camera.width, camera.height):
        raise ValueError(f"camera: width x height {camera.width}x{camera.height} does not match the video's {width}x{height} pixels")
    centre = backproject_to_height(camera, np.array([[camera.cx, camera.cy]]), 0.0)[0]
    if not np.all(np.isfinite(centre)):
        raise ValueError("camera: the image centre does not look down at the floor plane z = 0 (wrong camera file?)")
    sample = frames[:: max(1, frames.shape[0] // 16), ::2, ::2]  # enough for both checks, cheap
    grey = sample.mean(axis=-1)
    contrast = float(np.median(np.percentile(grey.reshape(len(grey), -1), 99, axis=1) - np.percentile(grey.reshape(len(grey), -1), 1, axis=1)))
    if contrast < MIN_CONTRAST:
        raise ValueError(f"video: the frames are blank (contrast {contrast:.0f} grey levels; black or a single colour): nothing to perceive")
    median = np.median(sample, axis=0)
    changed = (np.abs(sample.astype(np.float32) - median).max(axis=-1) > MOVING_DIFFERENCE).sum(axis=(1, 2)) * 4  # full-size px
    if int(changed.max()) < MOVING_PIXELS:
        raise ValueError("video: nothing moves (every frame equals the video's median image): no moving object to perceive")


def perceive_frames(frames: np.ndarray, camera: Camera, *, fps: float = 25.0, progress: bool = False,
                    segmenter: Segmenter | None = None, tracker: Tracker | None = None, lifter: Lifter | None = None,
                    object_size: float = DEFAULT_OBJECT_SIZE) -> tuple[Observations, dict]:
    """(F, H, W, 3) uint8 frames -> (Observations, intermediates dict with segments / tracks / lifted / timings).

    Raises ValueError (one line naming the problem) for input perception cannot work on
    (check_frames) and when no object is found: never an empty world.
    """
    check_frames(frames, camera)
    timings = {}
    began = time.perf_counter()
    segmenter = segmenter or ClassicalSegmenter()
    segments = segmenter.segment(frames, progress=progress)
    timings["segment_s"] = time.perf_counter() - began
    began = time.perf_counter()
    tracks = (tracker or HungarianTracker(object_size)).track(segments, camera)
    timings["track_s"] = time.perf_counter() - began
    began = time.perf_counter()
    lifted = (lifter or PrimitiveLifter(object_size)).lift(frames, segments, tracks, camera, progress=progress)
    timings["lift_s"] = time.perf_counter() - began
    objects = tuple(
        ObjectTrack(id=t.id, shape=default_shape(t.attributes.shape, object_size), frames=t.frames, positions=t.positions,
                    yaw=t.yaw, visible=t.visible, weights=t.weights, color=t.attributes.color, material=t.attributes.material)
        for t in lifted
    )
    if not objects:
        raise ValueError("video: no object found (something moves, but no sphere, cube or cylinder of the known size "
                         "explains it; is the camera file the one of this video?)")
    observations = Observations(objects=objects, fps=fps, num_frames=int(frames.shape[0]), camera=camera,
                                source={"kind": "perception", "method": "classical background + primitive fit"})
    return observations, {"segments": segments, "tracks": tracks, "lifted": lifted, "timings": timings}


def perceive(video_path: str | Path, camera: Camera, *, progress: bool = False) -> Observations:
    """Tracked objects of a static-camera tabletop video, on the plane z = 0.

    video_path: an mp4 (any format PyAV decodes); camera: intrinsics + pose
    (world.types.Camera, OpenCV convention) whose width x height must match the video.
    """
    frames, fps = read_video(video_path)
    observations, _ = perceive_frames(frames, camera, fps=fps, progress=progress)
    return observations


def instance_map(camera: Camera, lifted: list[LiftedTrack], frame: int, object_size: float = DEFAULT_OBJECT_SIZE) -> np.ndarray:
    """(H, W) int16 track id per pixel (-1 floor) from the fitted primitives at ``frame``, nearest surface wins."""
    depth = np.full((camera.height, camera.width), np.inf)
    ids = np.full((camera.height, camera.width), -1, dtype=np.int16)
    for track in lifted:
        where = np.nonzero(track.frames == frame)[0]
        if where.size == 0:
            continue
        k = int(where[0])
        yaw = 0.0 if np.isnan(track.yaw[k]) else float(track.yaw[k])
        window = primitive_window(camera, track.attributes.shape, track.positions[k], object_size)
        if window.empty:
            continue
        t = ray_depths(camera, track.attributes.shape, track.positions[k], object_size, yaw, window)
        region = depth[window.top:window.bottom, window.left:window.right]
        nearer = t < region
        region[nearer] = t[nearer]
        ids[window.top:window.bottom, window.left:window.right][nearer] = track.id
    return ids
