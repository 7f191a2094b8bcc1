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
from itertools import groupby
from pathlib import Path

import numpy as np
from scipy.optimize import linear_sum_assignment
from tqdm import tqdm

from perception.attributes import (
    color_of,
    color_probabilities,
    color_votes,
    material_of,
    material_probabilities,
    shape_overlap,
    shape_probabilities,
)
from perception.background import DEEP
from perception.geometry import primitive_window, ray_depths, silhouette
from perception.lift import Fit, cast, fit_cube, fit_detection, fit_primitive, initial_centre, shadow_explained
from perception.shadows import estimate_reach, shadow_sample
from perception.segment import MIN_SEGMENT_AREA, ClassicalSegmenter, body_of, own_shadow, paint_like_floor, pixel_hue_labels, sharpen_edges
from perception.track import HungarianTracker, track_piece
from perception.types import NEUTRAL, Attributes, Detection, FrameSegments, LiftedTrack, Lifter, Segmenter, Tracker, TrackState
from perception.video import read_video
from world.camera import backproject_to_height, centre_in_view
from world.observations import DEFAULT_OBJECT_SIZE, ObjectTrack, Observations, default_shape
from world.types import CLEVR_PALETTE_RGB as PALETTE_RGB, SHAPE_KINDS, AttributeBelief, Camera

MAX_ATTRIBUTE_FRAMES = 6  # isolated frames used to decide shape (a fit per frame and primitive)
MIN_CUT_PIECE_FRAMES = 10  # frames: a shorter piece of a cut track that joins nothing and never touches the border is dropped
INTERLEAVE_FRAMES = 3  # a sample of the other tracklet this close in time on both sides: the two take turns on one object
DUPLICATE_SIZES = 1.5  # tracklets closer than this many object sizes (radii) on most common frames are one object (see _close_frames)
STRAY_SHARE = 0.5  # share of its frames a track may spend inside longer tracks (see _without_strays) and still be an object
KEEP_SHARE = 0.5  # on a frame two joined tracklets both hold, the better supported one's sample stays unless it weighs less than this share of the other's
MAX_APPEARANCE_FRAMES = 16  # isolated frames used to decide colour / material (cheap per frame)
# Without isolated frames, a frame at the border decides attributes when its segment is at least MOST_IN_VIEW_AREA
# of the area the track's unsplit segments reach on MOST_IN_VIEW_FRAMES frames (_decisive_frames).
MOST_IN_VIEW_AREA = 0.8
MOST_IN_VIEW_FRAMES = 3
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
LINK_OVERLAP = 2  # samples two linked tracklets may hold where they overlap (strays one was born on or the other ended on; left out)
CLEAN_WEIGHT = 0.65  # a sample at least this good was fitted on a segment of its own (touching: x 0.6, split: x 0.3)
WEAK_STRAY_SHARE = 0.5  # of LINK_OVERLAP a left-out sample below CLEAN_WEIGHT takes: at a contact the pieces overlap by a few such
LINK_GATE = 0.45  # m: largest distance between a tracklet's predicted position and the next one's start ...
LINK_GATE_PER_FRAME = 0.02  # ... plus this per frame of gap (the prediction is held after 5 frames)
LINK_SPEED_SLACK = 1.5  # the jump across a gap may be this much more than the faster tracklet end's speed allows ...
JUMP_M = 0.25  # m between consecutive frames: more than any object moves (4 m/s is 0.16 m/frame) ...
JUMP_CONFIRM = 3  # ... with this many centres on each side holding their own course: another thing (_jump_cuts)
MAX_JUMP_TRANSITION = 1  # samples between the two courses (a segment of both things at the frame of the jump)
COLOUR_RUN_FRAMES = 10  # detections of one hue label on each side of a label change for it to be a colour cut's candidate
                        # (fewer give a noisy appearance: one brown cube's 5 frames read yellow and 9 read brown were 0.37 apart)
MAX_SPEED = 0.2  # m/frame (5 m/s at 25 fps): ... but never more than this per frame
MAX_LINK_APPEARANCE = 0.3  # appearance_distance above which two tracklets are different objects (red vs blue, not red vs brown)
SHAPE_MISMATCH_COST = 0.5  # added link cost when the tracklets were read as different shapes
LINK_REFUSED = 2.5  # link cost at which ending a tracklet is as good as continuing it (motion + appearance + shape terms)
APPEARANCE_FRAMES = 12  # frames along a tracklet whose pixels make its appearance
MIN_ATTRIBUTE_FRAMES = 10  # a joined track takes attributes from a tracklet at least this long when there is one


def _alone(det: Detection, segments: list[FrameSegments]) -> bool:
    """Whether the detection is the only segment of its connected component in its frame."""
    return sum(1 for d in segments[det.frame].detections if d.component == det.component) == 1


def _isolated_frames(track: TrackState, segments: list[FrameSegments]) -> list[int]:
    """Frames where the track's segment is whole: alone in its component, not split, not at the border."""
    areas = np.array([d.area for d in track.detections.values()])
    typical = float(np.median(areas))
    return [frame for frame, det in sorted(track.detections.items())
            if _alone(det, segments) and not det.split and not det.touches_border and det.area >= 0.6 * typical]


def _decisive_frames(track: TrackState, segments: list[FrameSegments]) -> list[int]:
    """Frames whose segments decide a track's attributes: its isolated frames (_isolated_frames); without any,
    its frames less those where the image border cuts off much of it (a segment touching the border smaller
    than MOST_IN_VIEW_AREA of the area its unsplit segments reach on MOST_IN_VIEW_FRAMES frames: a segment
    joined with a neighbour for a frame at a contact is no measure of the object).

    An object seen at the border shows a varying part of itself: a sliver fits every primitive about as well,
    a cube at its best yaw best, so frames that show little of it must not vote with the frames that show most
    of it (held-out set 97474: 7 of 14 wrong shapes were objects never seen whole, 6 of them read as cubes)."""
    isolated = _isolated_frames(track, segments)
    if isolated:
        return isolated
    areas = [det.area for det in track.detections.values() if not det.split] or [det.area for det in track.detections.values()]
    cut = MOST_IN_VIEW_AREA * sorted(areas)[-min(MOST_IN_VIEW_FRAMES, len(areas))]
    return [frame for frame, det in sorted(track.detections.items()) if not det.touches_border or det.area >= cut]


SAME_SEGMENT_SHIFT = 0.25  # px: centroid shift below which a segment of equal area and box is the same object pose
SAME_SEGMENT_AREA = 0.02  # relative area change allowed for the same (segmentation flickers by a few pixels)


def _same_segment(a: Detection, b: Detection) -> bool:
    """Whether two detections cover (nearly) the same pixels: equal box, area within 2 %, centroid within 0.25 px."""
    if a.touches_border or b.touches_border or a.split or b.split or abs(a.area - b.area) > SAME_SEGMENT_AREA * a.area:
        return False
    if (a.ys.min(), a.ys.max(), a.xs.min(), a.xs.max()) != (b.ys.min(), b.ys.max(), b.xs.min(), b.xs.max()):
        return False
    return bool(np.linalg.norm(a.centroid - b.centroid) < SAME_SEGMENT_SHIFT)


def _spread(frames: list[int], count: int) -> list[int]:
    if len(frames) <= count:
        return frames
    return [frames[int(round(k))] for k in np.linspace(0, len(frames) - 1, count)]


LIGHT_SAMPLES_PER_TRACK = 3  # frames of each coloured track that calibrate the light (shadows.estimate_reach)
MAX_LIGHT_SAMPLES = 18
MIN_LIGHT_SHAPE_SCORE = 0.7  # a coloured track explained less well by its primitive (a fragment) does not calibrate


def _appearance_frames(track: TrackState, segments: list[FrameSegments]) -> list[int]:
    """The frames whose pixels decide a track's colour and material: MAX_APPEARANCE_FRAMES spread over its
    decisive frames (_decisive_frames)."""
    return _spread(_decisive_frames(track, segments), MAX_APPEARANCE_FRAMES)


def _grey_paint(track: TrackState, frames: np.ndarray, appearance_frames: list[int]) -> bool:
    """Whether a track's colour (attributes.color_of on ``appearance_frames``) is grey."""
    return color_of([track.detections[f] for f in appearance_frames], frames) == "gray"


def _beside_shadows_only(state: TrackState, segments: list[FrameSegments]) -> list[int]:
    """Frames where the track's segment is whole (not split, not at the border) and shares its component with
    shadow-like segments only (hue-less, or the floor darkened on most pixels: a hard shadow on a tinted floor
    keeps the floor's hue, _deep_segment): its own shadow may touch it, another coloured object may not."""
    chosen = []
    for frame, det in sorted(state.detections.items()):
        others = [d for d in segments[frame].detections if d.component == det.component and d is not det]
        if not det.split and not det.touches_border and all(d.hue_label == NEUTRAL or _deep_segment(d, segments[frame].labels)
                                                            for d in others):
            chosen.append(frame)
    return chosen


def _deep_segment(det: Detection, labels: np.ndarray) -> bool:
    """Whether at least SHADOW_HUELESS of a segment's pixels are the floor darkened with its own chroma
    (background.DEEP; labels: the frame's (H, W) pixel labels)."""
    return bool(np.mean(labels[det.ys, det.xs] == DEEP) >= SHADOW_HUELESS)


def light_reach(camera: Camera, size: float, coloured: list[tuple[TrackState, LiftedTrack]],
                segments: list[FrameSegments]) -> np.ndarray | None:
    """The video's light as shadows.estimate_reach's (2,) reach, from coloured tracks (their tracker state and lifted
    track) that their primitive explains well, on frames where no other coloured thing touches them: their paint
    places them without help from the shadows."""
    candidates = []
    for state, track in coloured:
        if track.attributes.color == "gray" or track.attributes.shape_score < MIN_LIGHT_SHAPE_SCORE:
            continue
        whole = set(_beside_shadows_only(state, segments))
        usable = [i for i, frame in enumerate(track.frames) if int(frame) in whole]
        candidates += [(track, i) for i in _spread(usable, LIGHT_SAMPLES_PER_TRACK)]
    samples = []
    for track, i in (candidates[int(round(k))] for k in np.linspace(0, len(candidates) - 1, min(len(candidates), MAX_LIGHT_SAMPLES))):
        kind, centre = track.attributes.shape, track.positions[i]
        yaw = 0.0 if np.isnan(track.yaw[i]) else float(track.yaw[i])
        window, sil = silhouette(camera, kind, centre, size, yaw)
        samples.append(shadow_sample(camera, segments[int(track.frames[i])].labels, kind, centre, size, yaw, window, sil))
    return estimate_reach(samples)


class PrimitiveLifter:
    """Projected-primitive fit with the known object size (no learned weights)."""

    def __init__(self, object_size: float = DEFAULT_OBJECT_SIZE) -> None:
        self.size = object_size

    def shape_fits(self, camera: Camera, detection: Detection, labels: np.ndarray, free_top: bool = False,
                   reach: np.ndarray | None = None) -> dict[str, Fit]:
        """Per primitive kind, its best fit to one detection (labels: the frame's (H, W) pixel labels; free_top,
        reach: lift.fit_primitive's)."""
        start = initial_centre(camera, detection, self.size)
        return {"sphere": fit_primitive(camera, "sphere", start, self.size, 0.0, labels, detection, free_top=free_top, reach=reach),
                "cylinder": fit_primitive(camera, "cylinder", start, self.size, 0.0, labels, detection, free_top=free_top, reach=reach),
                "cube": fit_cube(camera, start, self.size, labels, detection, free_top=free_top, reach=reach)}

    def shape_scores(self, camera: Camera, track: TrackState, segments: list[FrameSegments], frames_used: list[int],
                     frames: np.ndarray, free_top: bool = False, reach: np.ndarray | None = None) -> dict[str, list[float]]:
        """Per primitive kind, the shape overlap (attributes.shape_overlap) of its best fit on each of ``frames_used``,
        judged on the segment without its mixed edge pixels (segment.sharpen_edges; frames: (F, H, W, 3) uint8;
        free_top, reach: lift.fit_primitive's; the segment's pixels a fit's shadow explains count as explained)."""
        scores = {kind: [] for kind in SHAPE_KINDS}
        for frame in frames_used:
            det, labels = sharpen_edges(frames[frame], segments[frame].labels, track.detections[frame])
            # fitted without the segment's own shadow: a sphere's contact shadow would draw its fit down onto it
            shadow = own_shadow(labels, det)
            for kind, fit in self.shape_fits(camera, body_of(det, shadow), labels, free_top, reach).items():
                scores[kind].append(shape_overlap(camera, kind, fit, self.size, det, labels, shadow, free_top,
                                                  shadow_explained(camera, kind, fit, self.size, det, labels, reach)))
        return scores

    def _lift_track(self, frames: np.ndarray, segments: list[FrameSegments], track: TrackState,
                   camera: Camera, reach: np.ndarray | None = None) -> tuple[LiftedTrack, dict[str, list[float]]] | None:
        """One tracklet lifted to the plane with its attributes, and its per-kind shape overlaps; None when no
        primitive of the known size explains it (a fragment, not an object). reach: the video's light
        (light_reach), given for grey tracks, whose segments may hold their shadows."""
        basis = _spread(_decisive_frames(track, segments), MAX_ATTRIBUTE_FRAMES)
        appearance_frames = _appearance_frames(track, segments)
        if reach is not None and not _grey_paint(track, frames, appearance_frames):
            reach = None  # a dark paint segmented hue-less (a brown metal body): its deep pixels are its body
        # an object with the floor's chroma may show its top as floor (lift.fit_primitive's free_top): most frames decide
        free_top = 2 * sum(paint_like_floor(frames[f], segments[f].labels, track.detections[f]) for f in basis) > len(basis)
        scores = self.shape_scores(camera, track, segments, basis, frames, free_top, reach)
        kind, _, shape_score = rank_shapes(scores)
        if shape_score < MIN_SHAPE_SCORE:
            return None
        attributes = decide_attributes([track.detections[f] for f in appearance_frames], frames, segments, scores)
        frame_ids, positions, yaws, weights = [], [], [], []
        previous: Fit | None = None
        reference: Detection | None = None  # the detection the previous fit was computed on
        for frame, det in sorted(track.detections.items()):
            if previous is not None and _same_segment(reference, det):
                fit = previous  # a resting object: the same pixels give the same pose (most frames of most videos)
            else:
                labels = segments[frame].labels
                # placed by its body: its own hard shadow (deep pixels of a coloured segment) would draw the fit onto it
                fit = fit_detection(camera, kind, body_of(det, own_shadow(labels, det)), labels, self.size, previous, free_top, reach)
                previous, reference = fit, det
            weight = float(np.clip(fit.score / 0.7, 0.0, 1.0))
            if det.touches_border:
                weight *= WEIGHT_BORDER
            if det.split or frame in track.merged:
                weight *= WEIGHT_SPLIT
            elif not _alone(det, segments):
                weight *= WEIGHT_TOUCHING
            frame_ids.append(frame)
            positions.append(fit.centre)
            yaws.append(fit.yaw if kind == "cube" else np.nan)
            weights.append(weight)
        frame_ids, positions, yaws, weights = _extend_through_border(
            camera, kind, self.size, frames.shape[0], track, np.asarray(frame_ids, dtype=np.int64),
            np.asarray(positions), np.asarray(yaws), np.asarray(weights))
        visible = centre_in_view(camera, positions)
        return LiftedTrack(track.id, attributes, frame_ids, positions, yaws, visible, weights), scores

    def lift(self, frames: np.ndarray, segments: list[FrameSegments], tracks: list[TrackState],
             camera: Camera, *, progress: bool = False) -> list[LiftedTrack]:
        bar = tqdm(total=len(tracks), desc="lift", unit="object", disable=not progress)
        lifted, appearance, states, scores_of = [], {}, {}, {}
        next_id = max((t.id for t in tracks), default=-1) + 1
        # coloured tracks first: placed by their paint, they calibrate the light whose shadows the grey ones may hold
        first = {}
        for track in tracks:
            if track.hue_label != NEUTRAL:
                first[track.id] = self._lift_track(frames, segments, track, camera)
                bar.update()
        coloured = [(track, first[track.id][0]) for track in tracks if first.get(track.id) is not None]
        reach = light_reach(camera, self.size, coloured, segments)
        for track in tracks:
            if track.id in first:
                result = first[track.id]
            elif reach is not None and _in_cast_shadows(track, [t for _, t in coloured], camera, self.size, reach) \
                    and _grey_paint(track, frames, _appearance_frames(track, segments)):
                bar.update()  # a coloured object's shadow (as _without_cast_shadows below): not lifted at all
                continue
            else:
                result = self._lift_track(frames, segments, track, camera, reach)
                bar.update()
            pieces = [(track, result)]
            jumps = [] if result is None else _jump_cuts(result[0], track)
            cuts = sorted(jumps + [c for c in _colour_cuts(track, frames) if all(abs(c - j) >= COLOUR_RUN_FRAMES for j in jumps)])
            if cuts:  # the tracklet took another thing's segments (or colour) from each cut on: each piece is lifted on its own
                bounds = [min(track.detections), *cuts, max(track.detections) + 1]
                runs = [[f for f in sorted(track.detections) if lo <= f < hi] for lo, hi in zip(bounds, bounds[1:])]
                pieces = []
                for run in runs:
                    piece = track_piece(track, run, next_id)
                    next_id += 1
                    pieces.append((piece, self._lift_track(frames, segments, piece, camera, None if piece.hue_label != NEUTRAL else reach)))
            for state, lifted_piece in pieces:
                states[state.id] = state
                if lifted_piece is None:  # no primitive of the known size explains it: a fragment, not an object
                    continue
                lifted.append(lifted_piece[0])
                scores_of[state.id] = lifted_piece[1]
                appearance[state.id] = track_appearance(state, frames, segments)
        bar.close()

        def explained(piece: LiftedTrack, anchor: LiftedTrack) -> bool:
            return _explained_by(camera, self.size, states[piece.id], anchor)

        def decide(group: list[LiftedTrack], source: LiftedTrack) -> Attributes:
            merged, pooled = _merged_state(group, states), _pooled_shape_scores(group, states, scores_of)
            # the joined track keeps the source's id: later joins (chains of joined groups) see all its frames
            states[source.id], scores_of[source.id] = merged, pooled
            return _redecide_attributes(merged, pooled, frames, segments)

        if reach is not None:  # before association: a shadow tracklet joined to its caster would move it
            lifted = _without_cast_shadows(lifted, states, appearance, camera, self.size, reach)
        associated = _associate(lifted, self.size, appearance, explained=explained, decide=decide)
        # A short piece of a track cut at a gap that joins nothing and appears and vanishes inside the image is
        # what the tracker's widened gate had attached to that track (a shadow, a reflection), not an object:
        # an object that is only briefly seen enters or leaves through the border.
        alone = {t.id: len(t.frames) for t in lifted if states[t.id].cut and len(t.frames) < MIN_CUT_PIECE_FRAMES
                 and not _at_border(states[t.id])}
        associated = [t for t in associated if alone.get(t.id) != len(t.frames)]
        associated = _without_strays(_without_shadows(associated, appearance, self.size), self.size)
        return _renumber(_untangle_contacts(associated, self.size, appearance))


def _jump_cuts(track: LiftedTrack, state: TrackState) -> list[int]:
    """Frames from which a tracklet follows another thing: between two consecutive frames its fitted centre
    moved more than JUMP_M (faster than objects move), the JUMP_CONFIRM centres after the jump all stay more
    than JUMP_M from where the JUMP_CONFIRM before were heading, and those before from where the ones after
    came from (a one-frame misfit breaks one of the two; a track that followed a reflection on a metal
    neighbour and then took the reflected object's own segment keeps both). The jump may take two frames
    (more than 2 x JUMP_M over them) with up to MAX_JUMP_TRANSITION samples between the courses: a segment of
    both things on the frame of the jump; such a sample starts the piece after. Samples extrapolated through
    the border are not looked at."""
    own = np.isin(track.frames, list(state.detections))
    frames, xy = track.frames[own].astype(float), track.positions[own, :2]

    def far_from_heading(points: slice, base: slice) -> bool:
        velocity = (xy[base.stop - 1] - xy[base.start]) / (frames[base.stop - 1] - frames[base.start])
        origin = base.stop - 1 if points.start > base.start else base.start
        heading = xy[origin] + velocity * (frames[points] - frames[origin])[:, None]
        return bool(np.all(np.linalg.norm(xy[points] - heading, axis=1) > JUMP_M))

    cuts, k = [], JUMP_CONFIRM - 1
    while k < len(frames) - JUMP_CONFIRM:
        before = slice(k + 1 - JUMP_CONFIRM, k + 1)
        for step in range(1, MAX_JUMP_TRANSITION + 2):  # the jump, or the jump over a transition sample
            after = slice(k + step, k + step + JUMP_CONFIRM)
            if (after.stop <= len(frames) and frames[k + step] - frames[k] == step
                    and np.linalg.norm(xy[k + step] - xy[k]) > step * JUMP_M
                    and far_from_heading(after, before) and far_from_heading(before, after)):
                cuts.append(int(frames[k + 1]))  # a transition sample goes with the piece after: a stray it starts on
                k += step - 1 + JUMP_CONFIRM  # the next piece needs its own JUMP_CONFIRM centres before another cut
                break
        else:
            k += 1
    return cuts


def _colour_cuts(track: TrackState, frames: np.ndarray) -> list[int]:
    """Frames from which a tracklet shows another object's colour: at a change of its detections' hue label
    between runs of at least COLOUR_RUN_FRAMES detections, the appearance (track_appearance) of all its
    detections before and of all from there on differ by more than MAX_LINK_APPEARANCE, the difference at
    which association refuses to join two tracklets. The tracker lets a track take a segment of another hue
    label next to where it was (a colour re-read at a contact); when that segment is a touching object of
    another colour, the track follows that object from then on and the object's own track ends, with no jump
    in position. A re-read that returns to the object's colour (a metal body mirroring a neighbour) leaves
    the appearance after the change the object's own. The largest such difference cuts, and each piece is
    looked at again (frames: (F, H, W, 3) uint8)."""
    seen = sorted(track.detections)
    runs, first = [], 0  # (hue label, index of the run's first detection, detections)
    for label, run in groupby(track.detections[frame].hue_label for frame in seen):
        count = sum(1 for _ in run)
        runs.append((label, first, count))
        first += count
    long = [run for run in runs if run[2] >= COLOUR_RUN_FRAMES]
    changes = [after[1] for before, after in zip(long, long[1:]) if before[0] != after[0]]
    best, cut = MAX_LINK_APPEARANCE, None
    for k in changes:
        distance = appearance_distance(track_appearance(track_piece(track, seen[:k]), frames),
                                       track_appearance(track_piece(track, seen[k:]), frames))
        if distance > best:
            best, cut = distance, k
    if cut is None:
        return []
    return (_colour_cuts(track_piece(track, seen[:cut]), frames) + [seen[cut]]
            + _colour_cuts(track_piece(track, seen[cut:]), frames))


def _at_border(track: TrackState) -> bool:
    """The track's first or last detection touches the image border."""
    frames = sorted(track.detections)
    return track.detections[frames[0]].touches_border or track.detections[frames[-1]].touches_border


def mean_overlaps(scores: dict[str, list[float]]) -> dict[str, float]:
    """Mean silhouette overlap J per primitive kind (0 for a kind without frames)."""
    return {kind: float(np.mean(v)) if v else 0.0 for kind, v in scores.items()}


def rank_shapes(scores: dict[str, list[float]]) -> tuple[str, float, float]:
    """(kind, margin over the runner-up, mean J of the kind) from per-frame overlaps per primitive kind."""
    means = mean_overlaps(scores)
    ranked = sorted(means, key=means.get, reverse=True)
    return ranked[0], means[ranked[0]] - means[ranked[1]], means[ranked[0]]


def decide_attributes(detections: list[Detection], frames: np.ndarray, segments: list[FrameSegments],
                      scores: dict[str, list[float]]) -> Attributes:
    """Colour, shape and material of one track, each with its probabilities: colour and material by the
    attribute rules on ``detections`` (frames spread over the track), shape from the per-frame primitive
    overlaps ``scores``. The one place Attributes are built, for tracklets and for joined tracks alike."""
    kind, margin, shape_score = rank_shapes(scores)
    votes = color_votes(detections, frames)
    color = color_of(detections, frames, votes)
    material, metal_probability = material_of(detections, frames, segments, color, kind)
    return Attributes(color=color, shape=kind, material=material, confidence=float(np.clip(margin * 5, 0, 1)),
                      metal_probability=metal_probability, shape_score=shape_score,
                      color_probabilities=color_probabilities(votes), shape_probabilities=shape_probabilities(mean_overlaps(scores)),
                      material_probabilities=material_probabilities(metal_probability))


EXPLAINED_SHARE = 0.8  # share of a tracklet's pixels inside another tracklet's fitted silhouette: a piece of that object
EXPLAINED_FRAMES = 8  # common frames (spread) on which the explanation is checked
PIECE_AREA = 0.6  # a piece's segments are smaller than this share of the anchor's silhouette (a whole object in front is not)


def _explained_by(camera: Camera, size: float, piece: TrackState, anchor: LiftedTrack) -> bool:
    """Whether a tracklet's segments lie inside another tracklet's fitted primitive (its silhouette at the
    anchor's fitted pose) on most of their common frames: a piece of the anchor's object (a highlight or a
    reflection tracked on its own), whose own fitted centre may be up to a radius off."""
    common = [int(f) for f in anchor.frames if int(f) in piece.detections]
    checked = _spread(common, EXPLAINED_FRAMES)
    if not checked or len(common) < 0.5 * len(piece.detections):
        return False
    index = {int(f): k for k, f in enumerate(anchor.frames)}
    inside = 0
    for frame in checked:
        k, det = index[frame], piece.detections[frame]
        yaw = 0.0 if np.isnan(anchor.yaw[k]) else float(anchor.yaw[k])
        window, sil = silhouette(camera, anchor.attributes.shape, anchor.positions[k], size, yaw)
        if window.empty or det.area > PIECE_AREA * sil.sum():
            continue
        ys, xs = det.ys - window.top, det.xs - window.left
        ok = (ys >= 0) & (ys < sil.shape[0]) & (xs >= 0) & (xs < sil.shape[1])
        inside += float(sil[ys[ok], xs[ok]].sum()) / det.area >= EXPLAINED_SHARE
    return inside > 0.5 * len(checked)


def _merged_state(group: list[LiftedTrack], states: dict[int, TrackState]) -> TrackState:
    """One TrackState holding every frame of a group's tracklets; a frame held by several gets the union of
    their pixels (the pieces of one object) with the colour label of the largest."""
    by_frame: dict[int, list[Detection]] = {}
    for track in group:
        for frame, det in states[track.id].detections.items():
            by_frame.setdefault(frame, []).append(det)
    detections = {}
    for frame, parts in by_frame.items():
        if len(parts) == 1:
            detections[frame] = parts[0]
            continue
        largest = max(parts, key=lambda d: d.area)
        flat = np.unique(np.concatenate([d.ys.astype(np.int64) * 100_000 + d.xs for d in parts]))
        detections[frame] = Detection(frame, (flat // 100_000).astype(np.int32), (flat % 100_000).astype(np.int32), largest.hue_label,
                                      any(d.touches_border for d in parts), largest.component, any(d.split for d in parts))
    merged = TrackState(id=group[0].id, hue_label=states[group[0].id].hue_label, detections=detections)
    merged.merged = set().union(*(states[t.id].merged for t in group))
    return merged


def _pooled_shape_scores(group: list[LiftedTrack], states: dict[int, TrackState],
                         scores_of: dict[int, dict[str, list[float]]]) -> dict[str, list[float]]:
    """Per-frame primitive overlaps of a group's tracklets pooled, leaving out a tracklet whose frames are
    mostly held by a better supported one (a piece: its overlaps are those of a part)."""
    pooled = {kind: [] for kind in SHAPE_KINDS}
    held: set[int] = set()
    for track in sorted(group, key=_support, reverse=True):
        own = set(int(f) for f in states[track.id].detections)
        if held and len(own & held) > 0.5 * len(own):
            continue
        held |= own
        for kind in SHAPE_KINDS:
            pooled[kind].extend(scores_of[track.id][kind])
    return pooled


def _redecide_attributes(merged: TrackState, pooled: dict[str, list[float]],
                         frames: np.ndarray, segments: list[FrameSegments]) -> Attributes:
    """Colour, shape and material of a joined track decided over ALL its frames: colour and material by the
    attribute rules on frames spread over the whole joined track (``merged``: pieces of one frame united),
    shape from the tracklets' pooled primitive overlaps (_pooled_shape_scores)."""
    chosen = _appearance_frames(merged, segments)
    return decide_attributes([merged.detections[f] for f in chosen], frames, segments, pooled)


def _extend_through_border(camera: Camera, kind: str, size: float, num_frames: int, track: TrackState,
                           frames: np.ndarray, positions: np.ndarray, yaws: np.ndarray, weights: np.ndarray):
    """Extend a track that enters (leaves) through the image border backwards (forwards) at constant
    velocity over the frames where its centre is already (still) in view but less of its
    silhouette than MIN_SEGMENT_AREA is inside the image (too little to be segmented), so that
    entry and exit frames follow the generator's visibility rule (world.camera.centre_in_view).
    Added frames get weight WEIGHT_EXTRAPOLATED.

    frames (T,), positions (T, 3) m, yaws (T,), weights (T,) -> the same, extended.
    """
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
            if not centre_in_view(camera, position[None])[0]:
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
    """One track from two tracklets of one object: all frames of both; on a frame both hold, ``keep``'s
    sample unless its weight is below KEEP_SHARE of the other's (a piece fitted on its own may weigh a little
    more than the whole object's sample and sit a radius off); attributes of ``keep`` (the better supported tracklet)."""
    frames = np.union1d(keep.frames, other.frames)
    rows = {}
    for track in (other, keep):  # keep comes second: its sample replaces other's unless it weighs under KEEP_SHARE of it
        for k, frame in enumerate(track.frames):
            current = rows.get(int(frame))
            if current is None or track.weights[k] >= KEEP_SHARE * current[0].weights[current[1]]:
                rows[int(frame)] = (track, k)
    pick = [rows[int(f)] for f in frames]
    return replace(keep, frames=frames.astype(np.int64),
                   positions=np.array([t.positions[k] for t, k in pick]), yaw=np.array([t.yaw[k] for t, k in pick]),
                   visible=np.array([t.visible[k] for t, k in pick]), weights=np.array([t.weights[k] for t, k in pick]))


HUELESS_SHARE, FLOOR_CHROMA_SHARE = 3, 4  # indices of track_appearance's two shares (0-2: chromaticity)


def track_appearance(track: TrackState, frames: np.ndarray, segments: list[FrameSegments] | None = None,
                     count: int = APPEARANCE_FRAMES) -> np.ndarray:
    """(5,) appearance of a tracklet over its whole life, over ``count`` frames spread along it: mean
    chromaticity (r, g, b sum to 1) of its pixels that have a hue, the fraction of hue-less pixels, and the
    fraction the background model found darkened with the floor's own chroma (background.DEEP; the hue-less
    fraction without ``segments``): a floor with a tint, or a sky-tinted shadow, has a hue and is still floor."""
    chroma_sum, coloured, floor_chroma, total = np.zeros(3), 0, 0, 0
    for frame in _spread(sorted(track.detections), count):
        det = track.detections[frame]
        rgb = frames[frame][det.ys, det.xs]
        labels = pixel_hue_labels(rgb, dark_hues=True)
        hued = rgb[labels != NEUTRAL].astype(np.float64)
        chroma_sum += (hued / np.maximum(hued.sum(axis=1, keepdims=True), 1.0)).sum(axis=0)
        coloured += len(hued)
        floor_chroma += int((segments[frame].labels[det.ys, det.xs] == DEEP).sum()) if segments is not None else len(rgb) - len(hued)
        total += len(rgb)
    chroma = chroma_sum / coloured if coloured else np.full(3, 1.0 / 3.0)
    return np.append(chroma, [1.0 - coloured / max(total, 1), floor_chroma / max(total, 1)])


def _palette_appearance(color: str) -> np.ndarray:
    """(5,) appearance (track_appearance's) of an ideal object of a palette colour (used when no pixels are at hand)."""
    rgb = np.asarray(PALETTE_RGB[color], dtype=float)
    grey = 1.0 if color == "gray" else 0.0
    return np.append(rgb / rgb.sum(), [grey, grey])


def appearance_distance(a: np.ndarray, b: np.ndarray) -> float:
    """Distance between two (5,) appearances: chromaticity difference plus half the hue-less fraction difference.
    Around 0.02 for one object seen under different shading, 0.15-0.25 for red/brown or brown/yellow, > 0.4 for red/blue."""
    return float(np.linalg.norm(a[:3] - b[:3]) + 0.5 * abs(a[HUELESS_SHARE] - b[HUELESS_SHARE]))


def _end_velocity(track: LiftedTrack, at_start: bool) -> np.ndarray:
    """(2,) m/frame plane velocity over the first (last) EXTRAPOLATION_BASE + 1 samples of a tracklet."""
    base = slice(0, EXTRAPOLATION_BASE + 1) if at_start else slice(-EXTRAPOLATION_BASE - 1, None)
    positions, frames = track.positions[base, :2], track.frames[base]
    return (positions[-1] - positions[0]) / max(int(frames[-1] - frames[0]), 1)


def _linked_pair(earlier: LiftedTrack, later: LiftedTrack,
                 appearance: dict[int, np.ndarray]) -> tuple[float, LiftedTrack, LiftedTrack] | None:
    """(cost, earlier, later) that ``later`` continues ``earlier``, with the samples left out of the link, or
    None when they cannot be one object. The cost is dimensionless (< LINK_REFUSED to link).

    Motion: ``earlier``'s constant-velocity prediction (held after 5 frames) must land within a gate of
    ``later``'s first position, and the jump across the gap must be one the tracklets' own speeds can
    make (a resting object does not reappear a metre away). Appearance: colour likelihood from the whole
    tracklets, soft (a colour re-read after a contact still joins) but refused when clearly another colour.
    Where the two overlap, the link is split at one frame s: ``earlier`` keeps its samples before s,
    ``later`` its samples from s on; s ranges over the overlap, and at most LINK_OVERLAP samples may be left
    out (cheapest first, then fewest): the strays ``later``'s tracker track was born on, the strays
    ``earlier``'s ended on, or some of each; a sample fitted on a touching or split segment (weight below
    CLEAN_WEIGHT) counts WEAK_STRAY_SHARE of one (at a contact the tracker's two pieces of one object
    overlap by a few such samples); more, and the two are seen at once: not one object's pieces in turn.
    Where they do not overlap, the last weak samples of ``earlier`` or the first of ``later`` (up to
    LINK_OVERLAP, each below CLEAN_WEIGHT) may be left out the same way: a tracklet that ends on a stray fit
    of a touching segment (40 cm off on a development video) would send its motion's prediction astray."""
    splits = np.union1d(later.frames[later.frames <= earlier.frames[-1]], earlier.frames[earlier.frames >= later.frames[0]])
    for count in range(1, LINK_OVERLAP + 1):  # or the last weak samples of ``earlier``, the first of ``later``
        if count < earlier.frames.size and np.all(earlier.weights[-count:] < CLEAN_WEIGHT):
            splits = np.union1d(splits, earlier.frames[[-count]])
        if count < later.frames.size and np.all(later.weights[:count] < CLEAN_WEIGHT):
            splits = np.union1d(splits, later.frames[[count]])
    options = []
    for split in np.append(splits, earlier.frames[-1] + 1):
        kept_earlier, kept_later = earlier.frames < split, later.frames >= split
        left_out = _stray_count(earlier.weights[~kept_earlier]) + _stray_count(later.weights[~kept_later])
        if left_out > LINK_OVERLAP or np.count_nonzero(kept_earlier) < 2 or np.count_nonzero(kept_later) < 2:
            continue
        trimmed_earlier, trimmed_later = _samples(earlier, kept_earlier), _samples(later, kept_later)
        cost = _motion_and_appearance_cost(trimmed_earlier, trimmed_later, appearance)
        if np.isfinite(cost):
            options.append((cost, left_out, trimmed_earlier, trimmed_later))
    if not options:
        return None
    cost, _, trimmed_earlier, trimmed_later = min(options, key=lambda option: option[:2])
    return cost, trimmed_earlier, trimmed_later


def _stray_count(weights: np.ndarray) -> float:
    """What left-out samples of these (n,) weights take of LINK_OVERLAP (_linked_pair)."""
    weak = int(np.count_nonzero(weights < CLEAN_WEIGHT))
    return weights.size - weak + WEAK_STRAY_SHARE * weak


def _motion_and_appearance_cost(earlier: LiftedTrack, later: LiftedTrack, appearance: dict[int, np.ndarray]) -> float:
    """The link cost (_linked_pair) of two tracklets that do not overlap in time; inf when refused."""
    gap = int(later.frames[0] - earlier.frames[-1])
    if gap > MAX_LINK_GAP:
        return np.inf
    colour = appearance_distance(appearance[earlier.id], appearance[later.id])
    if colour > MAX_LINK_APPEARANCE:
        return np.inf
    velocity = _end_velocity(earlier, at_start=False)
    predicted = earlier.positions[-1, :2] + velocity * min(gap, 5)
    gate = LINK_GATE + LINK_GATE_PER_FRAME * gap
    distance = float(np.linalg.norm(predicted - later.positions[0, :2]))
    speed = max(float(np.linalg.norm(velocity)), float(np.linalg.norm(_end_velocity(later, at_start=True))))
    jump = float(np.linalg.norm(later.positions[0, :2] - earlier.positions[-1, :2]))
    if distance > gate or jump > LINK_GATE + min(LINK_SPEED_SLACK * speed, MAX_SPEED) * gap:
        return np.inf
    shape = 0.0 if earlier.attributes.shape == later.attributes.shape else SHAPE_MISMATCH_COST
    return distance / gate + colour / MAX_LINK_APPEARANCE + shape


def _samples(track: LiftedTrack, kept: np.ndarray) -> LiftedTrack:
    """The tracklet with only the samples where the (T,) bool mask ``kept`` is true."""
    return replace(track, frames=track.frames[kept], positions=track.positions[kept], yaw=track.yaw[kept],
                   visible=track.visible[kept], weights=track.weights[kept])


def _support(track: LiftedTrack) -> float:
    return track.attributes.shape_score * len(track.frames)


def _attribute_source(group: list[LiftedTrack]) -> LiftedTrack:
    """The tracklet whose attributes a joined track keeps: the best primitive fit among tracklets long
    enough to judge (short fragments at contacts are often cut and misread), else the best supported."""
    long_enough = [t for t in group if len(t.frames) >= MIN_ATTRIBUTE_FRAMES]
    if long_enough:
        return max(long_enough, key=lambda t: (t.attributes.shape_score, len(t.frames)))
    return max(group, key=_support)


def _join(group: list[LiftedTrack], appearance: dict[int, np.ndarray], decide=None) -> LiftedTrack:
    """One track from tracklets of one object (frames merged by weight) with the id of _attribute_source
    and attributes decided over all the tracklets' frames by ``decide(group, source)`` (without it, the
    source's); the joined appearance is the frame-weighted mean of the parts'."""
    source = _attribute_source(group)
    ordered = sorted(group, key=_support, reverse=True)
    joined = ordered[0]
    for other in ordered[1:]:
        joined = _union(joined, other)
    joined = replace(joined, id=source.id, attributes=source.attributes if decide is None else decide(group, source))
    counts = np.array([len(t.frames) for t in group], dtype=float)
    appearance[source.id] = np.average([appearance[t.id] for t in group], axis=0, weights=counts)
    return joined


def _overlap(a: LiftedTrack, b: LiftedTrack) -> bool:
    return bool(np.intersect1d(a.frames, b.frames).size)


def _close_frames(a: LiftedTrack, b: LiftedTrack, size: float) -> int:
    """Common frames where two tracklets' centres are closer than DUPLICATE_SIZES object sizes, when that is
    most of their common frames; else 0. Two solid objects' centres are at least 2 sizes apart (touching), so
    closer is one object tracked twice; 1.5 leaves half a radius for the fits of touching objects and takes
    pieces whose own fit lies up to 1.5 radii off (a metal's mirrored or lit half, docs/benchmarks.md
    "Duplicates within one and a half radii")."""
    mine, close = _close_on_common_frames(a, b, size)
    if mine.size == 0:
        return _interleaved_close_frames(a, b, size)
    return int(close.sum()) if close.mean() > 0.5 else 0


def _close_on_common_frames(a: LiftedTrack, b: LiftedTrack, size: float) -> tuple[np.ndarray, np.ndarray]:
    """(indices into ``a``'s samples of the frames both tracklets hold, (same length,) bool: their centres are
    closer than DUPLICATE_SIZES object sizes there)."""
    _, mine, theirs = np.intersect1d(a.frames, b.frames, return_indices=True)
    return mine, np.linalg.norm(a.positions[mine, :2] - b.positions[theirs, :2], axis=1) < DUPLICATE_SIZES * size


def _interleaved_close_frames(a: LiftedTrack, b: LiftedTrack, size: float) -> int:
    """_close_frames of two tracklets that share no frame but take turns on one object (each frame held
    by one of them, as the tracker's pieces of one object cut at gaps are): a's samples that have a
    sample of b at most INTERLEAVE_FRAMES before and after are compared with b's position interpolated
    there."""
    compared = close = 0
    for frame, position in zip(a.frames, a.positions):
        after = int(np.searchsorted(b.frames, frame))
        if after == 0 or after == b.frames.size:
            continue
        f0, f1 = int(b.frames[after - 1]), int(b.frames[after])
        if frame - f0 > INTERLEAVE_FRAMES or f1 - frame > INTERLEAVE_FRAMES:
            continue
        share = (frame - f0) / (f1 - f0)
        between = (1.0 - share) * b.positions[after - 1, :2] + share * b.positions[after, :2]
        compared += 1
        close += int(np.linalg.norm(position[:2] - between) < DUPLICATE_SIZES * size)
    return close if compared and close / compared > 0.5 else 0


def _same_object(first: list[LiftedTrack], second: list[LiftedTrack], size: float) -> bool:
    """No tracklet of one group is seen apart from one of the other on their common frames."""
    return all(not _overlap(a, b) or _close_frames(a, b, size) for a in first for b in second)


def _associate(lifted: list[LiftedTrack], size: float, appearance: dict[int, np.ndarray] | None = None,
               explained=None, decide=None) -> list[LiftedTrack]:
    """Global association of tracklets over the whole video.

    appearance: track id -> (5,) track_appearance; without it, the palette colour of each tracklet.
    explained(piece, anchor) -> bool: the piece's segments lie inside the anchor's fitted primitive
    (_explained_by); decide(group, source) -> Attributes of a joined track (_redecide_attributes).

    1. Duplicates: two tracklets whose centres stay closer than DUPLICATE_SIZES object sizes on most
       common frames, or one explained by the other's object, are one object whatever colour or shape
       each was read as (two solid objects cannot be that close; a metal object split into a lit and a
       dark piece gives two such tracklets, the piece's own fit up to 1.5 radii off).
    2. Fragments: a tracklet that starts after another one ended (but for up to LINK_OVERLAP strays), near
       where that one was heading, with a speed it could have and a similar colour, continues it (an
       occlusion, a merge with a touching object, a lost detection, a colour re-read at a contact). All ends are assigned to
       all starts at once (Hungarian, each tracklet continues at most one), not greedily.
    """
    appearance = dict(appearance) if appearance is not None else {t.id: _palette_appearance(t.attributes.color) for t in lifted}
    groups: list[list[LiftedTrack]] = []
    for track in sorted(lifted, key=_support, reverse=True):
        # A group takes the tracklet when it is close to its best tracklet, or to another of its tracklets
        # and not seen apart from the best one (a piece of it that another piece bridges).
        scored = []  # (close frames, group) of the groups that take it
        for group in groups:
            close = _close_frames(track, group[0], size) or (
                max(_close_frames(track, member, size) for member in group) if _same_object([track], group[:1], size) else 0)
            if close or (explained is not None and _overlap(track, group[0]) and explained(track, group[0])):
                scored.append((close, group))
        if not scored:
            groups.append([track])
            continue
        best = max(scored, key=lambda item: item[0])[1]  # the first on a tie (groups are in order of support)
        matches = [group for _, group in scored]
        best.append(track)
        # A piece that duplicates two groups that never stand apart (one object seen before and after
        # a contact as two tracklets) makes them one object: the piece alone would keep them apart.
        for other in matches:
            if other is not best and _same_object(best, other, size):
                best.extend(other)
                groups.remove(other)
    kept = [_join(group, appearance, decide) if len(group) > 1 else group[0] for group in groups]

    count = len(kept)
    if count < 2:
        return kept
    pairs = [[_linked_pair(a, b, appearance) if i != j else None for j, b in enumerate(kept)] for i, a in enumerate(kept)]
    costs = np.array([[np.inf if pair is None else pair[0] for pair in row] for row in pairs])
    # Columns 0..n-1: "continues as tracklet j"; column n+i: "ends here" at cost LINK_REFUSED.
    table = np.full((count, 2 * count), 1e9)
    table[:, :count] = np.where(np.isfinite(costs), costs, 1e9)
    table[np.arange(count), count + np.arange(count)] = LINK_REFUSED
    rows, cols = linear_sum_assignment(table)
    successor = {int(i): int(j) for i, j in zip(rows, cols) if j < count and costs[i, j] < LINK_REFUSED}
    heads = set(range(count)) - set(successor.values())
    result = []
    for head in sorted(heads):
        chain, k = [kept[head]], head
        while k in successor:
            earlier, k = k, successor[k]
            # the samples where the two overlap were left out of the link: strays. The link was chosen
            # between whole tracklets; chain[-1] may since have lost its first samples to the link before
            # it, and if that leaves no split of the overlap, the whole tracklets' split holds.
            linked = _linked_pair(chain[-1], kept[k], appearance)
            if linked is None:
                _, _, continued = pairs[earlier][k]
                chain[-1] = _samples(chain[-1], chain[-1].frames < continued.frames[0])
                if chain[-1].frames.size == 0:
                    chain.pop()
            else:
                _, chain[-1], continued = linked
            chain.append(continued)
        result.append(_join(chain, appearance, decide) if len(chain) > 1 else chain[0])
    return result


CONTACT_SIZES = 3.0  # a contact episode of two tracks brings their centres closer than this many object sizes
CONTACT_WINDOW = 4  # clean samples of a track next to a contact that give its motion ...
WINDOW_SPAN = 10  # ... taken within this many frames of the contact
MAX_CONTACT_FRAMES = 20  # longer episodes are left alone (friction bends a straight-line extrapolation)
SWAP_MARGIN = 0.5  # object sizes: the crossed assignment must join the motions this much better
SOLID_SIZES = 1.0  # object sizes: a pairing whose two objects' relative position, joined straight over a contact, comes closer passes one through the other


def _line_at(track: LiftedTrack, rows: np.ndarray, frame: float) -> np.ndarray:
    """(2,) m: the straight-line (constant velocity) fit of ``track``'s samples at ``rows``, evaluated at ``frame``."""
    frames = track.frames[rows].astype(float)
    if frames.size < 2 or np.ptp(frames) == 0:
        return track.positions[rows, :2].mean(axis=0)
    slope, intercept = np.polyfit(frames - frames.mean(), track.positions[rows, :2], 1)
    return intercept + slope * (frame - frames.mean())


def _sides(track: LiftedTrack, first: int, last: int) -> tuple[np.ndarray, np.ndarray] | None:
    """Rows of the track's CONTACT_WINDOW clean samples before its own unclean run around frames
    [first, last] and after it (within WINDOW_SPAN frames); None when either side is too thin."""
    clean = track.weights >= CLEAN_WEIGHT
    before = np.flatnonzero(clean & (track.frames < first) & (track.frames >= first - WINDOW_SPAN))[-CONTACT_WINDOW:]
    after = np.flatnonzero(clean & (track.frames > last) & (track.frames <= last + WINDOW_SPAN))[:CONTACT_WINDOW]
    if before.size < 3 or after.size < 3:
        return None
    return before, after


def _contact_episodes(a: LiftedTrack, b: LiftedTrack, size: float) -> list[tuple[int, int]]:
    """(first, last) frame of each run of frames where two tracks are not both cleanly seen (a merged
    or split segment, a lost track) that brings them within CONTACT_SIZES sizes (at most
    MAX_CONTACT_FRAMES long, between two frames where both are)."""
    common, ia, ib = np.intersect1d(a.frames, b.frames, return_indices=True)
    clean_frames = common[(a.weights[ia] >= CLEAN_WEIGHT) & (b.weights[ib] >= CLEAN_WEIGHT)]
    episodes = []
    for k in range(clean_frames.size - 1):
        first, last = int(clean_frames[k]) + 1, int(clean_frames[k + 1]) - 1
        if last < first or last - first + 1 > MAX_CONTACT_FRAMES:
            continue
        inside = (common >= first - 1) & (common <= last + 1)
        separation = np.linalg.norm(a.positions[ia[inside], :2] - b.positions[ib[inside], :2], axis=1)
        if separation.size and separation.min() < CONTACT_SIZES * size:
            episodes.append((first, last))
    return episodes


def _join_miss(track_in: LiftedTrack, rows_in: np.ndarray, track_out: LiftedTrack, rows_out: np.ndarray) -> float:
    """m: how far apart one track's motion before a contact and another's after it are, both carried
    straight to the middle of the frames between them."""
    middle = 0.5 * (float(track_in.frames[rows_in[-1]]) + float(track_out.frames[rows_out[0]]))
    return float(np.linalg.norm(_line_at(track_in, rows_in, middle) - _line_at(track_out, rows_out, middle)))


def _crossed_at_contact(a: LiftedTrack, b: LiftedTrack, episode: tuple[int, int], size: float) -> tuple[LiftedTrack, LiftedTrack] | None:
    """a and b with their identities given back (``_uncrossed``) if they crossed at the episode, else None.

    Each object's straight-line motion before the episode and after it, carried to the frames
    between, must meet (a collision changes velocities, not positions; an occlusion neither). The
    tracker predicts through a contact at constant velocity and hands the identities back crossed
    when the mover stops and the one hit goes on, or when a lost track takes the other object;
    then the crossed pairing joins both motions much better. Unless the crossed pairing has the two
    objects pass through each other: their relative position as the contact begins, joined straight
    to the one as it ends, comes within SOLID_SIZES sizes of zero (two objects that meet head-on and
    bounce back join straight-line motions better crossed, yet solid bodies keep their sides).
    """
    first, last = episode
    sides_a, sides_b = _sides(a, first, last), _sides(b, first, last)
    if sides_a is None or sides_b is None:
        return None
    (a_in, a_out), (b_in, b_out) = sides_a, sides_b
    kept = _join_miss(a, a_in, a, a_out) + _join_miss(b, b_in, b, b_out)
    crossed = _join_miss(a, a_in, b, b_out) + _join_miss(b, b_in, a, a_out)
    if crossed + SWAP_MARGIN * size >= kept:
        return None
    before = _line_at(a, a_in, first) - _line_at(b, b_in, first)  # a's object relative to b's as the contact begins
    after = _line_at(b, b_out, last) - _line_at(a, a_out, last)  # ... and as it ends, were the identities crossed
    if _closest_to_zero(before, after) < SOLID_SIZES * size:
        return None
    return _uncrossed(a, b, first, last, (a_in, b_out), (b_in, a_out))


def _closest_to_zero(start: np.ndarray, end: np.ndarray) -> float:
    """m: distance from the origin of the segment from (2,) ``start`` to (2,) ``end``."""
    step = end - start
    share = float(np.clip(-start @ step / max(float(step @ step), 1e-12), 0.0, 1.0))
    return float(np.linalg.norm(start + share * step))


def _uncrossed(a: LiftedTrack, b: LiftedTrack, first: int, last: int, motion_a: tuple[np.ndarray, np.ndarray],
               motion_b: tuple[np.ndarray, np.ndarray]) -> tuple[LiftedTrack, LiftedTrack]:
    """a keeps its samples before ``first`` and takes b's after ``last`` (b the other way round);
    motion_a = (rows of a before, rows of b after) are a's object's motion (motion_b: b's object's).
    Each sample of either track inside [first, last] goes to the object whose motion (the side
    before up to the middle of the episode, after it beyond) passes closer; on a frame both
    objects claim, the higher weight wins."""
    middle = 0.5 * (first + last)
    owners = ((a, b), (b, a))  # (track before, track after) of each object

    def predicted(k: int, frame: int) -> np.ndarray:
        rows_in, rows_out = (motion_a, motion_b)[k]
        return _line_at(owners[k][0], rows_in, frame) if frame <= middle else _line_at(owners[k][1], rows_out, frame)

    claims: list[dict[int, tuple[LiftedTrack, int]]] = [{}, {}]
    for track in (a, b):
        for row in np.flatnonzero((track.frames >= first) & (track.frames <= last)):
            frame = int(track.frames[row])
            k = int(np.argmin([np.linalg.norm(track.positions[row, :2] - predicted(o, frame)) for o in (0, 1)]))
            held = claims[k].get(frame)
            if held is None or track.weights[row] > held[0].weights[held[1]]:
                claims[k][frame] = (track, row)
    fields = ("frames", "positions", "yaw", "visible", "weights")
    result = []
    for k, (head, tail) in enumerate(owners):
        parts = [(head, np.flatnonzero(head.frames < first))]
        parts += [(track, np.array([row])) for _, (track, row) in sorted(claims[k].items())]
        parts.append((tail, np.flatnonzero(tail.frames > last)))
        result.append(replace(head, **{name: np.concatenate([getattr(t, name)[rows] for t, rows in parts]) for name in fields}))
    return result[0], result[1]


def _untangle_contacts(tracks: list[LiftedTrack], size: float, appearance: dict[int, np.ndarray]) -> list[LiftedTrack]:
    """Give back identities the frame-to-frame tracker exchanged where two same-looking objects touched
    (_crossed_at_contact); pairs told apart by colour keep theirs (the tracker matches colour labels)."""
    tracks = list(tracks)
    for i in range(len(tracks)):
        for j in range(i + 1, len(tracks)):
            a, b = tracks[i], tracks[j]
            if appearance_distance(appearance[a.id], appearance[b.id]) > MAX_LINK_APPEARANCE:
                continue
            done = -1  # contacts up to this frame are settled
            while True:
                pending = [e for e in _contact_episodes(a, b, size) if e[0] > done]
                found = next(((e, pair) for e in pending if (pair := _crossed_at_contact(a, b, e, size)) is not None), None)
                if found is None:
                    break
                (_, done), (a, b) = found  # the samples changed: find the later contacts again
            tracks[i], tracks[j] = a, b
    return tracks


SHADOW_MIN_FRAMES = 10  # frames a shadow shares with its caster at least
SHADOW_SHARE = 0.9  # ... and this share of its own frames (a shadow is never seen without its caster)
SHADOW_TRAVEL_SIZES = 4.0  # object sizes the caster travels over those frames (at rest, anything keeps its offset)
SHADOW_OFFSET_SIZES = 0.5  # object sizes: 90th percentile of the offset's deviation from its median (one light, one offset)
SHADOW_NEAR_SIZES = 3.0  # object sizes: median distance from the caster (a shadow lies against its caster)
SHADOW_HUELESS = 0.8  # hue-less share, or share with the floor's chroma, of a shadow's pixels at least (the floor darkened) ...
CASTER_HUELESS = 0.5  # ... and of its caster's at most (a coloured object: which of the two is the shadow is clear)
SHADOW_MOTION_FRAMES = 5  # frames either side over which a caster's displacement says whether it moves at a frame


def _moving(path: np.ndarray, frames: np.ndarray, size: float) -> np.ndarray:
    """(N,) bool: at each of ``frames`` (N,) the caster, at plane positions ``path`` (N, 2) m, moves: from
    SHADOW_MOTION_FRAMES frames before to as many after (interpolated over gaps) it covers SHADOW_OFFSET_SIZES
    or more, farther than a shadow's offset may wander; so each moving frame tests a follower's offset."""
    probes = frames[:, None] + np.array([-SHADOW_MOTION_FRAMES, SHADOW_MOTION_FRAMES])  # (N, 2): before, after
    ends = np.stack([np.interp(probes, frames, path[:, axis]) for axis in (0, 1)], axis=-1)  # (N, 2, 2) m
    return np.linalg.norm(ends[:, 1] - ends[:, 0], axis=-1) >= SHADOW_OFFSET_SIZES * size


def _steady_offset(offset: np.ndarray, size: float) -> np.ndarray | None:
    """The median (2,) m of plane offsets (N, 2) m when they keep to it (90th percentile of the deviation under
    SHADOW_OFFSET_SIZES) and it lies against the caster (under SHADOW_NEAR_SIZES); else None."""
    median = np.median(offset, axis=0)
    deviation = np.linalg.norm(offset - median, axis=1)
    if np.linalg.norm(median) >= SHADOW_NEAR_SIZES * size or np.percentile(deviation, 90) >= SHADOW_OFFSET_SIZES * size:
        return None
    return median


def _shadow_offset(follower: LiftedTrack, caster: LiftedTrack, appearance: dict[int, np.ndarray],
                   size: float) -> tuple[np.ndarray, bool] | None:
    """(median plane offset (2,) m of ``follower`` from ``caster``, whether the caster travels meanwhile) when
    ``follower`` could be ``caster``'s shadow read as an object: seen only with it, against it, at one plane
    offset from it, hue-less where the caster is coloured (a floor darkened by the same light); else None.
    The offset is judged over all common frames, or over the frames the caster moves (_moving) when it travels
    on those: at rest anything keeps its offset, and a resting shadow is often cut by its neighbours' shadows
    (Blender seed 8181, scene 1: a brown sphere's shadow kept its offset within 4 cm over 2 m of travel, then
    lay 15 cm off it once the sphere rested in a cube's shadow). Deep hard shadows (Blender's sun, mean ratio
    to the floor about 0.4; POV-Ray's low-ambient light) are darker than background.DARK_OBJECT and so
    segmented as objects; the per-pixel test cannot tell them from grey objects, the geometry can
    (_without_shadows)."""
    if not _darkened_floor(appearance[follower.id]) or appearance[caster.id][HUELESS_SHARE] > CASTER_HUELESS:
        return None
    common, i_follower, i_caster = np.intersect1d(follower.frames, caster.frames, return_indices=True)
    if common.size < max(SHADOW_MIN_FRAMES, SHADOW_SHARE * follower.frames.size):
        return None
    path = caster.positions[i_caster, :2]
    offset = follower.positions[i_follower, :2] - path
    steps = np.linalg.norm(np.diff(path, axis=0), axis=1)
    if (median := _steady_offset(offset, size)) is not None:
        return median, bool(steps.sum() >= SHADOW_TRAVEL_SIZES * size)
    moving = _moving(path, common, size)
    if moving.sum() < SHADOW_MIN_FRAMES or steps[moving[1:]].sum() < SHADOW_TRAVEL_SIZES * size:
        return None
    median = _steady_offset(offset[moving], size)
    return None if median is None else (median, True)


CAST_SHADOW_FRAMES = 8  # frames (spread) of a grey track on which it is compared with the other tracks' shadows
CAST_SHADOW_SHARE = 0.8  # share of its segment's pixels not behind another primitive that lie in the others' shadows ...
MIN_SHADED_SHARE = 0.2  # ... and at least this share of all its pixels (wholly behind others: a duplicate, association's) ...
CAST_SHADOW_MAJORITY = 0.7  # ... on this share of those frames: a shadow, not an object


def _in_cast_shadows(state: TrackState, casters: list[LiftedTrack], camera: Camera, size: float, reach: np.ndarray) -> bool:
    """Whether the casters' shadows explain a tracklet (its tracker state; reach: the video's light, light_reach).
    On most of CAST_SHADOW_FRAMES frames spread over its detections, at least CAST_SHADOW_SHARE of its segment not
    behind a caster's primitive lies in the shadow of one at its fitted pose, and that is at least MIN_SHADED_SHARE
    of the segment (one wholly behind another tracklet's primitive, a piece or a duplicate of it, is association's
    to judge; pixels behind a primitive are its whatever they show)."""
    explained = 0
    checked = _spread(sorted(state.detections), CAST_SHADOW_FRAMES)
    for frame in checked:
        det = state.detections[frame]
        behind, shaded = np.zeros(det.area, dtype=bool), np.zeros(det.area, dtype=bool)
        for other in casters:
            k = np.searchsorted(other.frames, frame)
            if k >= len(other.frames) or other.frames[k] != frame:
                continue
            yaw = 0.0 if np.isnan(other.yaw[k]) else float(other.yaw[k])
            window, sil, _, shade = cast(camera, other.attributes.shape, other.positions[k], size, yaw, reach=reach)
            ys, xs = det.ys - window.top, det.xs - window.left
            inside = (ys >= 0) & (ys < sil.shape[0]) & (xs >= 0) & (xs < sil.shape[1])
            behind[inside] |= sil[ys[inside], xs[inside]]
            shaded[inside] |= shade[ys[inside], xs[inside]]
        seen_shaded = (shaded & ~behind).sum()
        if seen_shaded >= CAST_SHADOW_SHARE * (~behind).sum() and seen_shaded >= MIN_SHADED_SHARE * det.area:
            explained += 1
    return explained >= CAST_SHADOW_MAJORITY * len(checked)


def _darkened_floor(appearance: np.ndarray) -> bool:
    """Whether a tracklet's pixels (track_appearance's (5,)) look like the floor darkened by a shadow: at least
    SHADOW_HUELESS of them hue-less or with the floor's own chroma (background.DEEP)."""
    return bool(max(appearance[HUELESS_SHARE], appearance[FLOOR_CHROMA_SHARE]) >= SHADOW_HUELESS)


def _without_cast_shadows(tracks: list[LiftedTrack], states: dict[int, TrackState], appearance: dict[int, np.ndarray],
                          camera: Camera, size: float, reach: np.ndarray) -> list[LiftedTrack]:
    """The tracks without the shadow-like ones that the other tracks' shadows explain (_in_cast_shadows): a shadow
    cut off from its caster's segment, which a grey caster's (a grey cube's) is, and which _without_shadows does not
    judge, or the shadow of a resting caster when no other shadow of the video is tracked. Shadow-like: read grey,
    or its pixels the floor darkened (_darkened_floor): a hard shadow on a tinted floor keeps the floor's hue and
    is voted that colour (Blender dev seed 98787, scene 3: four brown tracks, shadows of resting objects on a warm
    floor). A grey object standing in another's shadow still rises out of it in the image; a coloured object's
    paint is not the floor's chroma."""
    def shadow_like(track: LiftedTrack) -> bool:
        return track.attributes.color == "gray" or _darkened_floor(appearance[track.id])

    return [track for track in tracks
            if not shadow_like(track) or not states.get(track.id) or not states[track.id].detections
            or not _in_cast_shadows(states[track.id], [t for t in tracks if t is not track], camera, size, reach)]


def _without_shadows(tracks: list[LiftedTrack], appearance: dict[int, np.ndarray], size: float) -> list[LiftedTrack]:
    """The tracks less those that are another track's shadow. A shadow cast by one light moves rigidly with its
    object, which another object does only while pushed, never over its whole life: a track that keeps one
    offset from a caster that travels (_shadow_offset) is its shadow. At rest anything keeps its offset, but all
    shadows of one video lie at about one offset from their casters (one light, objects of one size): a
    resting pair is a shadow when its offset is within SHADOW_OFFSET_SIZES of a travelling shadow's or of
    another resting pair's (another follower and another caster; two grey objects do not sit at one offset
    from two others by chance)."""
    pairs = [(follower, caster, found) for follower in tracks for caster in tracks if caster is not follower
             for found in [_shadow_offset(follower, caster, appearance, size)] if found is not None]
    shadows = {follower.id for follower, _, (_, travels) in pairs if travels}
    for follower, caster, (offset, _) in pairs:
        if any(np.linalg.norm(offset - other) < SHADOW_OFFSET_SIZES * size
               for other_follower, other_caster, (other, _) in pairs
               if other_follower is not follower and other_caster is not caster):
            shadows.add(follower.id)
    return [t for t in tracks if t.id not in shadows]


def _without_strays(tracks: list[LiftedTrack], size: float) -> list[LiftedTrack]:
    """The tracks less those that lie inside other objects most of their life: a track whose centre is within
    DUPLICATE_SIZES object sizes of some longer track on more than STRAY_SHARE of its frames. Two solid objects'
    centres are at least 2 sizes apart, so such a track is pieces of its neighbours (a dark face, a shadow or a
    reflection that the tracker carried from one touching object to the next); no single neighbour holds it on
    most common frames (_close_frames), so association kept it as an object of its own."""
    strays = set()
    for track in tracks:
        inside = np.zeros(track.frames.size, dtype=bool)
        for other in tracks:
            if other is track or other.frames.size <= track.frames.size:
                continue
            mine, close = _close_on_common_frames(track, other, size)
            inside[mine[close]] = True
        if inside.mean() > STRAY_SHARE:
            strays.add(track.id)
    return [t for t in tracks if t.id not in strays]


def _renumber(lifted: list[LiftedTrack]) -> list[LiftedTrack]:
    """Ids 0..K-1 in order of first appearance."""
    ordered = sorted(lifted, key=lambda t: (int(t.frames[0]), t.id))
    return [replace(t, id=k) for k, t in enumerate(ordered)]


BLANK_DIFFERENCE = 4.0  # grey levels: a pixel this far from its frame's median colour is not that colour (see MOVING_PIXELS)
MOVING_PIXELS = 60  # px: a frame with fewer pixels than this off the video's median image shows no motion (off its own
# median colour by BLANK_DIFFERENCE: shows nothing, blank)
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
    sample = frames[:: max(1, frames.shape[0] // 16), ::2, ::2].astype(np.float32)  # enough for both checks, cheap
    # Blank: no frame has MOVING_PIXELS off its own median colour (a small object on a flat floor is under
    # 1 % of the pixels, so a percentile spread would call it blank).
    off_colour = (np.abs(sample - np.median(sample, axis=(1, 2), keepdims=True)).max(axis=-1) > BLANK_DIFFERENCE).sum(axis=(1, 2)) * 4  # full-size px
    if int(off_colour.max()) < MOVING_PIXELS:
        raise ValueError(f"video: the frames are blank (no frame has {MOVING_PIXELS} px more than {BLANK_DIFFERENCE:.0f} grey levels off "
                         "its own colour; black or a single colour): nothing to perceive")
    median = np.median(sample, axis=0)
    changed = (np.abs(sample - median).max(axis=-1) > MOVING_DIFFERENCE).sum(axis=(1, 2)) * 4  # full-size px
    if int(changed.max()) < MOVING_PIXELS:
        raise ValueError("video: nothing moves (every frame equals the video's median image): no moving object to perceive")


def attribute_belief(track: LiftedTrack) -> AttributeBelief | None:
    """The track's attribute probabilities as a world belief (None when the lifter gave none);
    support_frames: frames with a usable position (weight > 0)."""
    attributes = track.attributes
    if not (attributes.color_probabilities and attributes.material_probabilities and attributes.shape_probabilities):
        return None
    return AttributeBelief.from_mappings(attributes.color_probabilities, attributes.material_probabilities,
                                         attributes.shape_probabilities, int(np.count_nonzero(track.weights > 0)))


def perceive_frames(frames: np.ndarray, camera: Camera, *, fps: float = 25.0, progress: bool = False,
                    segmenter: Segmenter | None = None, tracker: Tracker | None = None, lifter: Lifter | None = None,
                    object_size: float = DEFAULT_OBJECT_SIZE) -> tuple[Observations, dict]:
    """(F, H, W, 3) uint8 frames -> (Observations, intermediates dict with segments / tracks / lifted / timings).

    Raises ValueError (one line naming the problem) for input perception cannot work on
    (check_frames) and when no object is found: never an empty world.
    """
    check_frames(frames, camera)
    timings: dict[str, float] = {}  # per stage: wall seconds (<stage>_s) and CPU seconds of this process (<stage>_cpu_s)

    def timed(stage: str, work):
        wall, cpu = time.perf_counter(), time.process_time()
        result = work()
        timings[f"{stage}_s"] = time.perf_counter() - wall
        timings[f"{stage}_cpu_s"] = time.process_time() - cpu
        return result

    segmenter = segmenter or ClassicalSegmenter(camera, object_size)
    segments = timed("segment", lambda: segmenter.segment(frames, progress=progress))
    tracks = timed("track", lambda: (tracker or HungarianTracker(object_size)).track(segments, camera))
    lifted = timed("lift", lambda: (lifter or PrimitiveLifter(object_size)).lift(frames, segments, tracks, camera, progress=progress))
    objects = tuple(
        ObjectTrack(id=t.id, shape=default_shape(t.attributes.shape, object_size), frames=t.frames, positions=t.positions,
                    yaw=t.yaw, visible=t.visible, weights=t.weights, color=t.attributes.color, material=t.attributes.material,
                    attribute_belief=attribute_belief(t))
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
