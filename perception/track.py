"""Multi-object tracking on the support plane with Hungarian assignment.

Each detection's centroid is back-projected to the plane of object centres
(z = object half size) for a rough ground position; tracks predict with
constant velocity and are matched to detections of the same colour label by
ground distance within a gate that widens while a track is unseen (occlusion,
merges); a detection of another colour label is taken only by a track seen in
the last RELABEL_MAX_GAP frames, or within GATE_BASE of its prediction after at most RELABEL_NEAR_MAX_GAP unseen frames. A segment holding two same-coloured tracks
(objects that touch, also one merged into the other for up to SPLIT_MAX_GAP
frames) and larger than one of them is split between them by k-means on pixel
coordinates seeded at the predicted positions. A track is then cut wherever it went unseen for more than
MAX_TRACK_GAP frames: the widened gate of a lost track bridges to whatever of its colour shows up (a
reflection of an object on a metal neighbour, seen on a frame here and there, then the object itself),
and the pipeline's global association over the whole video (gates on motion, speed and appearance) is the
place to bridge gaps. Tracks (pieces) seen in fewer than MIN_TRACK_FRAMES frames are dropped and ids are
renumbered 0..K-1 by first appearance.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment

from perception.types import Detection, FrameSegments, TrackState
from world.camera import backproject_to_height, project
from world.observations import DEFAULT_OBJECT_SIZE
from world.types import Camera

GATE_BASE = 0.45  # m: largest jump between consecutive frames (4 m/s is 0.16 m/frame, plus segmentation noise)
GATE_PER_MISSED_FRAME = 0.12  # m per unseen frame (0.04 cured POV-Ray dev scene 12 but cost 4 more switches over that dev set)
GATE_MAX = 2.0  # m
HUE_MISMATCH_COST = 1.0  # m-equivalent penalty: a colour label change is allowed but costly
MIN_TRACK_FRAMES = 4
MAX_TRACK_GAP = 4  # frames: a track unseen longer is cut there; global association (pipeline._associate) rejoins its pieces
MIN_TRACK_AREA = 150  # px: a real object is larger than this in at least one frame
SPLIT_SECOND_AREA = 0.5  # a segment larger than the biggest owner's usual area plus this share of the next one's holds them all
SPLIT_MAX_GAP = 30  # frames: a track unseen this long still claims its part of a same-coloured segment it sits in
RELABEL_MAX_GAP = 2  # frames: a track unseen longer takes a detection of another colour label only within GATE_BASE ...
RELABEL_NEAR_MAX_GAP = 10  # frames: ... and only if unseen at most this long (a colour re-read follows a contact at once;
                           # a track lost for longer would take another object entering where it was lost)


class HungarianTracker:
    """Ground-plane constant-velocity tracker with colour-aware Hungarian matching."""

    def __init__(self, object_size: float = DEFAULT_OBJECT_SIZE) -> None:
        self.object_size = object_size

    def _ground(self, camera: Camera, detection: Detection) -> np.ndarray:
        point = backproject_to_height(camera, detection.centroid[None], self.object_size)[0, :2]
        return point if np.all(np.isfinite(point)) else np.array([0.0, 1e3])

    def track(self, segments: list[FrameSegments], camera: Camera) -> list[TrackState]:
        tracks: list[TrackState] = []
        for frame_segments in segments:
            frame = frame_segments.frame
            detections = list(frame_segments.detections)
            live = [t for t in tracks if t.detections]
            detections = self._split_shared(detections, live, frame, camera)
            grounds = [self._ground(camera, d) for d in detections]
            cost = np.full((len(live), len(detections)), 1e6)
            for i, track in enumerate(live):
                predicted, gap = self._predict(track, frame)
                gate = min(GATE_BASE + GATE_PER_MISSED_FRAME * (gap - 1), GATE_MAX)
                for j, det in enumerate(detections):
                    distance = float(np.linalg.norm(grounds[j] - predicted))
                    if distance > gate:
                        continue
                    if det.hue_label == track.hue_label:
                        cost[i, j] = distance
                    elif gap <= RELABEL_MAX_GAP or (distance <= GATE_BASE and gap <= RELABEL_NEAR_MAX_GAP):
                        # a colour re-read (metal highlights, contacts); only the widened gate of a lost track
                        # is kept to its own colour, so that it cannot grab another object passing by
                        cost[i, j] = distance + HUE_MISMATCH_COST
            matched = set()
            if live and detections:
                rows, cols = linear_sum_assignment(cost)
                for i, j in zip(rows, cols):
                    if cost[i, j] < 1e6:
                        live[i].detections[frame] = detections[j]
                        live[i].ground[frame] = grounds[j]
                        if detections[j].split:
                            live[i].merged.add(frame)
                        matched.add(j)
            for j, det in enumerate(detections):
                if j not in matched:
                    tracks.append(TrackState(id=len(tracks), hue_label=det.hue_label, detections={frame: det}, ground={frame: grounds[j]}))
            for track in tracks:  # the colour label follows the majority of the track's pixels
                if frame in track.detections:
                    track.hue_label = _majority_hue(track)
        pieces = [piece for t in tracks for piece in _split_at_gaps(t, MAX_TRACK_GAP)]
        kept = [t for t in pieces if len(t.detections) >= MIN_TRACK_FRAMES and max(d.area for d in t.detections.values()) >= MIN_TRACK_AREA]
        kept.sort(key=lambda t: (min(t.detections), t.id))
        for new_id, track in enumerate(kept):
            track.id = new_id
        return kept

    def _predict(self, track: TrackState, frame: int) -> tuple[np.ndarray, int]:
        """Predicted ground xy (m) at ``frame`` and the number of frames since last seen."""
        seen = sorted(track.ground)
        last = seen[-1]
        gap = frame - last
        position = track.ground[last]
        if len(seen) >= 2 and seen[-1] - seen[-2] <= 3:
            velocity = (track.ground[seen[-1]] - track.ground[seen[-2]]) / (seen[-1] - seen[-2])
            position = position + velocity * min(gap, 5)  # do not extrapolate far through occlusions
        return position, gap

    def _split_shared(self, detections: list[Detection], live: list[TrackState], frame: int, camera: Camera) -> list[Detection]:
        """Split segments that hold two or more recently seen same-coloured tracks."""
        claims = []  # (track, predicted pixel (u, v)) of every track that may own part of a segment this frame
        for track in live:
            predicted, gap = self._predict(track, frame)
            if gap > SPLIT_MAX_GAP:  # merged into a touching same-coloured object since: still inside it
                continue
            pixel = project(camera, np.array([predicted[0], predicted[1], self.object_size]))
            if np.all(np.isfinite(pixel)):
                claims.append((track, pixel))
        result = []
        for det in detections:
            left, right, top, bottom = det.xs.min() - 3, det.xs.max() + 3, det.ys.min() - 3, det.ys.max() + 3
            owners = [(track, pixel) for track, pixel in claims
                      if track.hue_label == det.hue_label and left <= pixel[0] <= right and top <= pixel[1] <= bottom]
            if len(owners) < 2:
                result.append(det)
                continue
            usual = sorted((float(np.median([d.area for d in t.detections.values()][-10:])) for t, _ in owners), reverse=True)
            if det.area < usual[0] + SPLIT_SECOND_AREA * usual[1]:
                result.append(det)
                continue
            result.extend(_kmeans_split(det, np.array([p for _, p in owners])))
        return result


def _split_at_gaps(track: TrackState, max_gap: int) -> list[TrackState]:
    """The track cut wherever it went unseen for more than ``max_gap`` frames (pieces keep its id for now)."""
    frames = sorted(track.detections)
    runs, start = [], 0
    for k in range(1, len(frames)):
        if frames[k] - frames[k - 1] - 1 > max_gap:
            runs.append(frames[start:k])
            start = k
    runs.append(frames[start:])
    if len(runs) == 1:
        return [track]
    return [track_piece(track, run) for run in runs]


def track_piece(track: TrackState, run: list[int], piece_id: int | None = None) -> TrackState:
    """The part of a track on the frames ``run`` (sorted), marked as cut; it keeps the track's id unless given one."""
    piece = TrackState(id=track.id if piece_id is None else piece_id, hue_label=track.hue_label,
                       detections={f: track.detections[f] for f in run}, ground={f: track.ground[f] for f in run},
                       merged={f for f in track.merged if run[0] <= f <= run[-1]}, cut=True)
    piece.hue_label = _majority_hue(piece)
    return piece


def _majority_hue(track: TrackState) -> int:
    weights: dict[int, int] = {}
    for det in track.detections.values():
        weights[det.hue_label] = weights.get(det.hue_label, 0) + det.area
    return max(weights, key=weights.get)


def _kmeans_split(det: Detection, seeds: np.ndarray, iterations: int = 5) -> list[Detection]:
    """Split a segment's pixels among K seeds (K, 2) pixel (u, v) by k-means on pixel coordinates."""
    points = np.stack([det.xs, det.ys], axis=1).astype(float)
    centres = seeds.astype(float).copy()
    for _ in range(iterations):
        nearest = np.argmin(((points[:, None, :] - centres[None]) ** 2).sum(-1), axis=1)
        for k in range(len(centres)):
            if np.any(nearest == k):
                centres[k] = points[nearest == k].mean(axis=0)
    pieces = []
    for k in range(len(centres)):
        chosen = nearest == k
        if chosen.sum() == 0:
            continue
        pieces.append(Detection(det.frame, det.ys[chosen], det.xs[chosen], det.hue_label, det.touches_border, det.component, split=True))
    return pieces
