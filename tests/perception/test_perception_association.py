"""Global association over tracklets (perception.pipeline._associate) on hand-made tracklets."""

from __future__ import annotations

import numpy as np

from dataclasses import replace

from perception.pipeline import COLOUR_RUN_FRAMES, _associate, _colour_cuts, _jump_cuts, _palette_appearance, _without_strays
from perception.types import Attributes, Detection, LiftedTrack, TrackState
from world.types import CLEVR_PALETTE_RGB as PALETTE_RGB

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


def test_a_colour_reread_after_a_contact_still_joins_but_another_colour_does_not():
    before = _tracklet(0, range(0, 50), (0.0, 0.0), (0.02, 0.0), color="red", score=0.95)  # the better fit keeps its colour
    reread = _tracklet(1, range(53, 128), (0.02 * 53, 0.0), (0.02, 0.0), color="brown")
    appearance = {0: _palette_appearance("red"), 1: _palette_appearance("brown")}
    (joined,) = _associate([before, reread], SIZE, appearance)
    assert joined.attributes.color == "red" and len(joined.frames) == 50 + 75
    appearance[1] = _palette_appearance("blue")
    assert len(_associate([before, replace(reread, attributes=replace(reread.attributes, color="blue"))], SIZE, appearance)) == 2


def test_a_resting_object_does_not_reappear_far_away():
    resting = _tracklet(0, range(0, 50), (0.0, 0.0), (0.0, 0.0))
    elsewhere_resting = _tracklet(1, range(60, 128), (0.6, 0.0), (0.0, 0.0))  # inside the 0.65 m prediction gate, but nothing moved
    assert len(_associate([resting, elsewhere_resting], SIZE)) == 2
    hit_away = _tracklet(2, range(60, 128), (0.6, 0.0), (0.05, 0.0))  # leaves fast: it could have covered the jump
    assert len(_associate([resting, hit_away], SIZE)) == 1


def test_ends_are_assigned_globally_not_cheapest_first():
    # a's cheapest continuation is c, but then b has none; the global assignment gives a->d? no: a->c, b->d
    # only when both are possible; here a can continue c or d and b only c, so a must take d.
    a = _tracklet(0, range(0, 40), (0.0, 0.0), (0.02, 0.0))
    b = _tracklet(1, range(0, 40), (0.0, 1.0), (0.02, -0.02))
    c = _tracklet(2, range(45, 128), (0.02 * 45, 0.1), (0.02, 0.0))
    d = _tracklet(3, range(45, 128), (0.02 * 45 + 0.3, -0.15), (0.02, 0.0))
    joined = _associate([a, b, c, d], SIZE)
    assert len(joined) == 2
    starts = sorted((tuple(np.round(t.positions[0, :2], 2)), tuple(np.round(t.positions[-1, :2], 2))) for t in joined)
    assert starts[0][0] == (0.0, 0.0) and abs(starts[0][1][1] - (-0.15)) < 1e-6  # a -> d
    assert starts[1][0] == (0.0, 1.0) and abs(starts[1][1][1] - 0.1) < 1e-6  # b -> c


def test_duplicates_of_one_object_join_whatever_each_was_read_as():
    whole = _tracklet(0, range(0, 128), (0.0, 0.0), (0.01, 0.0), color="red", shape="cylinder", score=0.99)
    dark_piece = _tracklet(1, range(20, 128), (0.2 + 0.05, 0.02), (0.01, 0.0), color="brown", shape="sphere", score=0.9)
    (merged,) = _associate([dark_piece, whole], SIZE)
    assert merged.attributes.color == "red" and merged.attributes.shape == "cylinder" and len(merged.frames) == 128


def test_a_piece_fitted_more_than_a_radius_off_still_joins_its_object():
    """A lit or mirrored piece of an object, fitted on its own, sits up to ~1.4 radii from the object's centre
    (Blender and POV-Ray metals); two solid objects never come closer than 2 radii, so it is the same object."""
    whole = _tracklet(0, range(0, 128), (0.0, 0.0), (0.01, 0.0), color="blue", shape="cube", score=0.99)
    piece = _tracklet(1, range(10, 90), (0.1 + 0.27, 0.0), (0.01, 0.0), color="gray", shape="sphere", score=0.7)
    (merged,) = _associate([piece, whole], SIZE)
    assert merged.attributes.color == "blue" and len(merged.frames) == 128


def test_two_touching_objects_moving_together_stay_two():
    """Two objects pushed along in contact: their measured centres scatter around 2 radii apart (down to 1.6),
    never close enough to be one object."""
    rng = np.random.default_rng(3)
    first = _tracklet(0, range(0, 128), (0.0, 0.0), (0.01, 0.0), color="red")
    second = _tracklet(1, range(0, 128), (2 * SIZE, 0.0), (0.01, 0.0), color="red")
    second = replace(second, positions=second.positions + np.column_stack([rng.uniform(-0.4, 0.3, 128) * SIZE, np.zeros((128, 2))]))
    assert len(_associate([first, second], SIZE)) == 2


def test_on_a_frame_both_hold_the_better_supported_tracklet_keeps_its_sample():
    """A piece whose samples weigh a little more than the object's own (a bright reflection fits its small
    primitive well) does not replace the object's positions; it only fills the frames the object lacks."""
    whole = _tracklet(0, [f for f in range(0, 128) if not 50 <= f < 55], (0.0, 0.0), (0.01, 0.0), score=0.95)
    whole = replace(whole, weights=np.full(len(whole.frames), 0.5))
    piece = _tracklet(1, range(40, 60), (0.4 + 0.15, 0.0), (0.01, 0.0), color="gray", score=0.6)
    piece = replace(piece, weights=np.full(len(piece.frames), 0.6))
    (merged,) = _associate([piece, whole], SIZE)
    by_frame = dict(zip(merged.frames.tolist(), merged.positions[:, 0]))
    assert all(abs(by_frame[f] - 0.01 * f) < 1e-9 for f in whole.frames.tolist())  # the object's own samples everywhere it has one
    assert all(abs(by_frame[f] - (0.15 + 0.01 * f)) < 1e-9 for f in range(50, 55))  # the piece fills the gap


def test_two_tracklets_taking_turns_on_one_object_join():
    """The tracker's pieces of one object cut at gaps can hold alternate frames (no frame in common):
    compared at the other's interpolated position they are one object."""
    first = _tracklet(0, [f for f in range(0, 104) if f < 96 or f in (99, 100, 102)], (0.0, 0.0), (0.01, 0.0), score=0.9)
    second = _tracklet(1, [97, 98, 101, *range(103, 128)], (0.97, 0.0), (0.01, 0.0), score=0.8)
    (merged,) = _associate([first, second], SIZE)
    assert len(merged.frames) == len(first.frames) + len(second.frames)


def test_two_objects_taking_turns_in_the_detections_stay_two():
    # two same-looking objects side by side, 2.2 radii apart, each seen on alternate frames
    first = _tracklet(0, range(0, 128, 2), (0.0, 0.0), (0.02, 0.0))
    second = _tracklet(1, range(1, 128, 2), (0.02, 2.2 * SIZE), (0.02, 0.0))
    assert len(_associate([first, second], SIZE)) == 2


def test_a_tracklet_born_on_two_strays_before_its_predecessor_ends_continues_it():
    # dev seed 7373, scene 1: the object's first tracklet ends at frame 27; the one that carries it on from 28
    # was born on two stray detections at 23 and 25 (a piece of a neighbour, 0.6 m away)
    before = _tracklet(0, range(0, 28), (0.0, 0.0), (0.02, 0.0))
    after = _tracklet(1, range(28, 128), (0.02 * 28, 0.0), (0.02, 0.0))
    strays = np.array([[0.9, 0.6, SIZE], [0.9, 0.6, SIZE]])
    born_on_strays = replace(after, frames=np.concatenate([[23, 25], after.frames]), positions=np.concatenate([strays, after.positions]),
                             yaw=np.full(102, np.nan), visible=np.ones(102, bool), weights=np.ones(102))
    (joined,) = _associate([born_on_strays, before], SIZE)
    assert np.array_equal(joined.frames, np.arange(128)) and np.allclose(joined.positions[:, 1], 0.0)  # no stray kept
    # three samples before the other ends are more than strays: another object's tracklet
    three = replace(born_on_strays, frames=np.concatenate([[21, 23, 25], after.frames]),
                    positions=np.concatenate([strays[:1], strays, after.positions]), yaw=np.full(103, np.nan),
                    visible=np.ones(103, bool), weights=np.ones(103))
    assert len(_associate([three, before], SIZE)) == 2


def test_a_tracklet_that_ends_on_a_stray_after_its_continuation_starts_is_continued():
    # Blender dev seed 7707, scene 1: a grey sphere resting at the border is tracked on frames 0-37 and 37-127;
    # the first tracklet's last sample (frame 37, weight 0.32) is another detection 0.64 m away
    before = _tracklet(0, range(0, 37), (0.0, 0.0), (0.0, 0.0))
    after = _tracklet(1, range(37, 128), (0.0, 0.0), (0.0, 0.0))
    ends_on_stray = replace(before, frames=np.append(before.frames, 37), positions=np.vstack([before.positions, [0.49, 0.42, SIZE]]),
                            yaw=np.full(38, np.nan), visible=np.ones(38, bool), weights=np.append(before.weights, 0.32))
    (joined,) = _associate([after, ends_on_stray], SIZE)
    assert np.array_equal(joined.frames, np.arange(128)) and np.allclose(joined.positions[:, :2], 0.0)  # no stray kept
    # three samples after the other starts are more than strays: another object's tracklet
    strays = np.array([[0.49, 0.42, SIZE]] * 3)
    three = replace(before, frames=np.append(before.frames, [37, 38, 39]), positions=np.vstack([before.positions, strays]),
                    yaw=np.full(40, np.nan), visible=np.ones(40, bool), weights=np.ones(40))
    assert len(_associate([after, three], SIZE)) == 2


def test_a_link_leaves_out_a_stray_on_each_side_of_one_split_frame():
    # Blender dev seed 7171, scene 6: a blue cube's tracklet ends at frame 59 on a stray 0.4 m ahead; the one that
    # carries it on was born on a stray at frame 54 and holds the cube from 59: split at 59, one stray each side
    before = _tracklet(0, range(0, 59), (0.0, 0.0), (0.02, 0.0))
    after = _tracklet(1, range(59, 128), (0.02 * 59, 0.0), (0.02, 0.0))
    ends_on_stray = replace(before, frames=np.append(before.frames, 59), positions=np.vstack([before.positions, [1.6, 0.05, SIZE]]),
                            yaw=np.full(60, np.nan), visible=np.ones(60, bool), weights=np.ones(60))
    born_on_stray = replace(after, frames=np.insert(after.frames, 0, 54), positions=np.vstack([[0.98, -0.1, SIZE], after.positions]),
                            yaw=np.full(70, np.nan), visible=np.ones(70, bool), weights=np.ones(70))
    (joined,) = _associate([born_on_stray, ends_on_stray], SIZE)
    assert np.array_equal(joined.frames, np.arange(128)) and np.allclose(joined.positions[:, 1], 0.0)  # no stray kept
    # two strays on one side and one on the other are more than LINK_OVERLAP: two objects
    two_strays = replace(born_on_stray, frames=np.insert(born_on_stray.frames, 0, 52),
                         positions=np.vstack([[0.5, 0.6, SIZE], born_on_stray.positions]), yaw=np.full(71, np.nan),
                         visible=np.ones(71, bool), weights=np.ones(71))
    assert len(_associate([two_strays, ends_on_stray], SIZE)) == 2


def test_strays_fitted_on_touching_segments_count_half():
    # fresh seed 41414, scene 46: a cyan sphere hits a green cube; its tracklet ends at frame 18 on the cube (a
    # touching segment, weight 0.6) and the one that carries it on was born on the cube at 15 and 16 (0.6, 0.49):
    # three strays, each a touching segment's, at a contact
    def with_strays(track, frames, positions, weights, at_end):
        join = (lambda a, b: np.concatenate([a, b])) if at_end else (lambda a, b: np.concatenate([b, a]))
        count = len(track.frames) + len(frames)
        return replace(track, frames=join(track.frames, np.asarray(frames)), positions=join(track.positions, np.asarray(positions)),
                       yaw=np.full(count, np.nan), visible=np.ones(count, bool), weights=join(track.weights, np.asarray(weights)))

    before = _tracklet(0, range(0, 18), (0.0, 0.0), (0.05, 0.0), color="cyan")
    after = _tracklet(1, range(19, 128), (0.05 * 19, 0.0), (0.05, 0.0), color="cyan")
    on_cube = [[0.95, 0.4, SIZE]]
    ends_on_cube = with_strays(before, [18], on_cube, [0.6], at_end=True)
    born_on_cube = with_strays(after, [15, 16], on_cube * 2, [0.6, 0.49], at_end=False)
    (joined,) = _associate([born_on_cube, ends_on_cube], SIZE)
    assert np.array_equal(joined.frames, np.delete(np.arange(128), 18)) and np.allclose(joined.positions[:, 1], 0.0)
    # the same three samples fitted on segments of their own: seen at once, two objects
    clean = [with_strays(before, [18], on_cube, [1.0], at_end=True), with_strays(after, [15, 16], on_cube * 2, [1.0, 1.0], at_end=False)]
    assert len(_associate(clean, SIZE)) == 2


def _state(track: LiftedTrack) -> TrackState:
    detection = Detection(0, np.zeros(1, np.int32), np.zeros(1, np.int32), 0, False, 0)
    return TrackState(track.id, 0, detections={int(f): detection for f in track.frames},
                      ground={int(f): p[:2] for f, p in zip(track.frames, track.positions)})


def test_a_tracklet_that_jumps_onto_another_thing_is_cut_there_and_a_one_frame_misfit_is_not():
    # Blender dev seed 7171, scene 11: a purple reflection on a metal neighbour was tracked from frame 2, and
    # at frame 27 the tracklet jumped 0.36 m onto the purple sphere itself and followed it (the tracker's gate
    # allows the jump); it is cut there, so the sphere's part can continue the sphere's own first tracklet
    reflection = _tracklet(0, range(2, 27), (-0.09, -0.03), (0.0, 0.0))
    sphere = _tracklet(0, range(27, 128), (-0.23, -0.36), (0.02, 0.0))
    jumped = replace(sphere, frames=np.concatenate([reflection.frames, sphere.frames]),
                     positions=np.concatenate([reflection.positions, sphere.positions]), yaw=np.full(126, np.nan),
                     visible=np.ones(126, bool), weights=np.ones(126))
    assert _jump_cuts(jumped, _state(jumped)) == [27]
    # one misfit 0.4 m off an object's course, back on it the next frame: no cut
    course = _tracklet(0, range(0, 60), (0.0, 0.0), (0.02, 0.0))
    misfit = replace(course, positions=course.positions + np.where(course.frames[:, None] == 20, [0.0, 0.4, 0.0], 0.0))
    assert _jump_cuts(misfit, _state(misfit)) == []
    # a fast object (0.16 m a frame, 4 m/s) is not cut either
    fast = _tracklet(0, range(0, 60), (0.0, 0.0), (0.16, 0.0))
    assert _jump_cuts(fast, _state(fast)) == []


def test_a_jump_over_one_transition_sample_is_cut_before_it():
    # Blender dev seed 7272, scene 14: a green track on another thing at x = 1.42 m went to 1.10 on frame 57 (a
    # segment of both) and to 0.75 on frame 58, on the green cube, and followed it: cut at 57
    other = _tracklet(0, range(52, 57), (1.47, -1.65), (-0.01, -0.01))
    cube = _tracklet(0, range(58, 100), (0.75, -1.93), (-0.01, -0.01))
    transition = np.array([[1.10, -1.77, SIZE]])
    jumped = replace(cube, frames=np.concatenate([other.frames, [57], cube.frames]),
                     positions=np.concatenate([other.positions, transition, cube.positions]), yaw=np.full(48, np.nan),
                     visible=np.ones(48, bool), weights=np.ones(48))
    assert _jump_cuts(jumped, _state(jumped)) == [57]
    # an object struck to the top speed (0.02 then 0.16 m a frame, 0.32 m over two frames) is not cut
    slow = _tracklet(0, range(0, 30), (0.0, 0.0), (0.02, 0.0))
    fast = _tracklet(0, range(30, 60), (0.58 + 0.16, 0.0), (0.16, 0.0))
    struck = replace(fast, frames=np.concatenate([slow.frames, fast.frames]), positions=np.concatenate([slow.positions, fast.positions]),
                     yaw=np.full(60, np.nan), visible=np.ones(60, bool), weights=np.ones(60))
    assert _jump_cuts(struck, _state(struck)) == []


def test_a_track_inside_its_neighbours_most_of_its_life_is_not_an_object():
    """Two objects resting 3 sizes apart (the gap between them one size wide) for 60 frames; a grey tracklet
    sits on the first for 10 frames and on the second for the next 10 (a dark face the tracker carried from one
    to the other): inside longer tracks on all of its frames, but on half of them for each, so association
    keeps it; it is no object. A third object resting against the first (centres 2.1 sizes apart, touching)
    stays, and so does a track that comes within 1.5 sizes of the first on only 5 of its 20 frames (misfits
    at a contact)."""
    first = _tracklet(0, range(0, 60), (0.0, 0.0), (0.0, 0.0))
    second = _tracklet(1, range(0, 60), (3 * SIZE, 0.0), (0.0, 0.0), color="blue")
    hopper = _tracklet(2, range(20, 40), (0.0, 0.05), (0.0, 0.0), color="gray")
    hopper = replace(hopper, positions=np.where((hopper.frames < 30)[:, None], hopper.positions,
                                                hopper.positions + np.array([3 * SIZE, 0.0, 0.0])))
    touching = _tracklet(3, range(0, 50), (0.0, 2.1 * SIZE), (0.0, 0.0), color="green")
    passing = _tracklet(4, range(20, 40), (-0.77, -0.25), (0.06, 0.0), color="yellow")  # inside the first on frames 31-35
    kept = _without_strays([first, second, hopper, touching, passing], SIZE)
    assert [t.id for t in kept] == [0, 1, 3, 4]
    assert len(_associate([first, second, hopper], SIZE)) == 3  # association alone keeps the hopper


def _painted_track(paints: list[tuple[str, int]]) -> tuple[TrackState, np.ndarray]:
    """A tracklet on one 8 x 8 px patch whose pixels have the given palette paints for the given numbers of
    frames in turn, and its (F, 16, 16, 3) frames; each detection's hue label is its paint's."""
    from perception.segment import pixel_hue_labels

    total = sum(n for _, n in paints)
    frames = np.full((total, 16, 16, 3), 90, np.uint8)
    ys, xs = (a.ravel().astype(np.int32) for a in np.mgrid[4:12, 4:12])
    detections, frame = {}, 0
    for paint, count in paints:
        rgb = np.asarray(PALETTE_RGB[paint], np.uint8)
        label = int(np.bincount(pixel_hue_labels(rgb[None]) + 1).argmax()) - 1
        for _ in range(count):
            frames[frame][ys, xs] = rgb
            detections[frame] = Detection(frame, ys, xs, label, False, 0)
            frame += 1
    return TrackState(0, detections[0].hue_label, detections=detections, ground={f: np.zeros(2) for f in detections}), frames


def test_a_tracklet_that_takes_on_another_objects_colour_is_cut_there_and_a_reread_is_not():
    # fresh held-out set 52525, scene 85: a red cube's track took the grey cube it touched (a segment of another
    # hue label next to it, which the tracker allows at a contact) and followed it for the rest of the video
    # with no jump in position; cut where the grey starts
    took_grey, frames = _painted_track([("red", 45), ("gray", 80)])
    assert _colour_cuts(took_grey, frames) == [45]
    # a metal body mirroring a purple neighbour for 12 frames, then its own red again: the track is one object
    mirrored, frames = _painted_track([("red", 20), ("purple", 12), ("red", 70)])
    assert _colour_cuts(mirrored, frames) == []
    # red read as brown from a contact on (appearance 0.15-0.25 apart): association would join them, so no cut
    reread, frames = _painted_track([("red", 40), ("brown", 60)])
    assert _colour_cuts(reread, frames) == []
    # another colour for fewer than COLOUR_RUN_FRAMES detections at the end: not enough to cut
    brief, frames = _painted_track([("red", 60), ("blue", COLOUR_RUN_FRAMES - 1)])
    assert _colour_cuts(brief, frames) == []


def test_a_chain_whose_middle_tracklet_lost_its_first_samples_still_joins(monkeypatch):
    """The links are chosen between whole tracklets; a middle tracklet then loses the strays it was born on to
    the link before it, and the link after it may no longer split (too few samples left, as a real video with
    a two-sample middle piece showed): the whole tracklets' split holds, never a crash."""
    import perception.pipeline as pipeline

    def weak_start(track, frames):
        stray = track.frames < frames  # fitted on a touching segment, off the object
        return replace(track, weights=np.where(stray, 0.6, 1.0), positions=track.positions + np.outer(stray, [0.0, 0.5, 0.0]))

    a = _tracklet(0, range(0, 19), (0.0, 0.0), (0.02, 0.0))
    b = weak_start(_tracklet(1, range(17, 41), (0.02 * 17, 0.0), (0.02, 0.0)), 19)
    c = weak_start(_tracklet(2, range(39, 128), (0.02 * 39, 0.0), (0.02, 0.0)), 41)
    whole_starts = {0, 17, 39}
    linked_pair = pipeline._linked_pair

    def refused_once_trimmed(earlier, later, appearance):
        return None if int(earlier.frames[0]) not in whole_starts else linked_pair(earlier, later, appearance)

    monkeypatch.setattr(pipeline, "_linked_pair", refused_once_trimmed)
    (chain,) = _associate([a, b, c], SIZE)
    assert np.all(np.diff(chain.frames) > 0) and chain.frames[0] == 0 and chain.frames[-1] == 127
    assert np.allclose(chain.positions[:, 0], 0.02 * chain.frames)


def test_a_tracklet_ending_on_a_stray_fit_still_links_to_its_continuation():
    """A tracklet whose last sample is a weak fit 40 cm off (a touching segment, as on a development video)
    predicts its motion astray; leaving that sample out, the next tracklet continues it. A clean last sample
    there is the object's own, and the link is refused."""
    before = _tracklet(0, range(0, 40), (0.0, 0.0), (0.02, 0.0))
    stray = before.positions.copy()
    stray[-1, 1] += 0.4
    weights = before.weights.copy()
    weights[-1] = 0.4
    after = _tracklet(1, range(40, 128), (0.02 * 40, 0.0), (0.02, 0.0))
    (joined,) = _associate([replace(before, positions=stray, weights=weights), after], SIZE)
    assert len(joined.frames) == 39 + 88 and np.allclose(joined.positions[:, 1], 0.0)
    assert len(_associate([replace(before, positions=stray), after], SIZE)) == 2
