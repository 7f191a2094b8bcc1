"""A lost track does not grab another object of its colour a metre away (HungarianTracker's widened gate).

Found on the POV-Ray dev set (seed 7505, scene 12: three green objects): a track lost for 9 frames after a
contact took a resting green cube 1.4 m from where it was lost. The tracklets are joined later, if at
all, by the global association (pipeline._associate), which checks speed and appearance.
"""

from __future__ import annotations

from perception.track import HungarianTracker
from tests.perception.test_perception_tracker import CAMERA, SIZE, _frames
from world.types import COLORS

GREEN = COLORS.index("green")


def test_a_lost_track_does_not_take_a_same_coloured_object_a_metre_away():
    # object A moves at 0.04 m/frame and is lost at frame 10 (occluded, or merged into a neighbour);
    # 8 frames later object B of the same colour appears 1.1 m from A's prediction and rests there
    frames = [[((-1.0 + 0.04 * f, 0.0), GREEN)] for f in range(10)] + [[] for _ in range(8)]
    frames += [[((-0.6, 1.1), GREEN)] for _ in range(18, 40)]
    tracks = HungarianTracker(SIZE).track(_frames(frames), CAMERA)
    spans = sorted((min(t.detections), max(t.detections)) for t in tracks)
    assert spans == [(0, 9), (18, 39)], f"tracklets span {spans}: a lost track took the other object"


def test_a_briefly_lost_track_keeps_its_object():
    # the same object lost for 3 frames and seen again on its course: one track
    frames = [[((-1.0 + 0.04 * f, 0.0), GREEN)] if not 10 <= f < 13 else [] for f in range(30)]
    tracks = HungarianTracker(SIZE).track(_frames(frames), CAMERA)
    assert len(tracks) == 1 and len(tracks[0].detections) == 27
