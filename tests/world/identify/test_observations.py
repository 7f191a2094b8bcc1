"""Observations: the adapters and their errors."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest

from world.observations import ObjectTrack, Observations, default_shape


def _annotation(frames: int = 5) -> dict:
    """A two-object CLEVRER-format annotation; object 1 enters at frame 2."""
    trajectory = []
    for f in range(frames):
        trajectory.append(
            {
                "frame_id": f,
                "objects": [
                    {"object_id": 0, "location": [0.1 * f, 0.0, 0.2], "orientation": [0, 0, 0, 1],
                     "velocity": [2.5, 0, 0], "angular_velocity": [0, 0, 0], "inside_camera_view": True},
                    {"object_id": 1, "location": [1.0, 0.5, 0.2], "orientation": [0, 0, 0.38268343, 0.92387953],
                     "velocity": [0, 0, 0], "angular_velocity": [0, 0, 0], "inside_camera_view": f >= 2},
                ],
            }
        )
    return {
        "scene_index": 7,
        "video_filename": "video_00007.mp4",
        "object_property": [
            {"object_id": 0, "color": "red", "material": "metal", "shape": "cube"},
            {"object_id": 1, "color": "blue", "material": "rubber", "shape": "sphere"},
        ],
        "motion_trajectory": trajectory,
        "collision": [],
    }


def test_from_clevrer_annotation_reads_tracks_and_visibility(tmp_path):
    path = tmp_path / "annotation_00007.json"
    path.write_text(json.dumps(_annotation()))
    observations = Observations.from_clevrer_annotation(path)
    assert observations.num_frames == 5
    cube, sphere = observations.objects
    assert (cube.color, cube.material, cube.shape.kind) == ("red", "metal", "cube")
    np.testing.assert_allclose(cube.positions[:, 0], 0.1 * np.arange(5))
    # Out-of-view frames are kept but do not count.
    np.testing.assert_array_equal(sphere.visible, [False, False, True, True, True])
    np.testing.assert_array_equal(sphere.weights, [0, 0, 1, 1, 1])
    assert sphere.yaw[0] == pytest.approx(np.pi / 4, abs=1e-6)


def test_round_trip_through_dict():
    observations = Observations.from_clevrer_annotation(_annotation())
    again = Observations.from_dict(json.loads(json.dumps(observations.to_dict())))
    for a, b in zip(observations.objects, again.objects):
        np.testing.assert_array_equal(a.frames, b.frames)
        np.testing.assert_allclose(a.positions, b.positions)
        np.testing.assert_array_equal(a.weights, b.weights)
        assert (a.color, a.material, a.shape) == (b.color, b.material, b.shape)


def _broken(mutate) -> dict:
    document = copy.deepcopy(_annotation())
    mutate(document)
    return document


@pytest.mark.parametrize(
    "document, message",
    [
        (_broken(lambda d: d["object_property"][1].update(shape="pyramid")), "shape"),
        (_broken(lambda d: d["object_property"].append(dict(d["object_property"][0]))), "duplicate object_id"),
        (_broken(lambda d: d["motion_trajectory"][3]["objects"][0].update(location=[float("nan"), 0, 0])), "NaN"),
        (_broken(lambda d: d["motion_trajectory"][1]["objects"][0].update(object_id=9)), "object_id 9"),
        (_broken(lambda d: d.pop("motion_trajectory")), "motion_trajectory"),
        (_broken(lambda d: d["motion_trajectory"][2].update(frame_id=1)), "twice"),
        (_broken(lambda d: d["motion_trajectory"][0]["objects"][0].update(location=[1, 2])), "location"),
    ],
)
def test_bad_annotations_name_the_problem(document, message):
    with pytest.raises(ValueError, match=message):
        Observations.from_clevrer_annotation(document)


def test_missing_file_is_a_clear_error(tmp_path):
    with pytest.raises(FileNotFoundError, match="no such annotation"):
        Observations.from_clevrer_annotation(tmp_path / "nope.json")


@pytest.mark.parametrize(
    "field, value, message",
    [
        ("frames", np.array([0, 2, 2]), "strictly increasing"),
        ("weights", np.array([1.0, 2.0, 1.0]), "weights"),
        ("positions", np.zeros((3, 2)), "positions"),
    ],
)
def test_track_validation(field, value, message):
    arguments = dict(
        id=0, shape=default_shape("cube"), frames=np.arange(3), positions=np.zeros((3, 3)),
        yaw=np.zeros(3), visible=np.ones(3, bool), weights=np.ones(3),
    )
    arguments[field] = value
    with pytest.raises(ValueError, match=message):
        ObjectTrack(**arguments)


def test_frames_beyond_video_are_rejected():
    track = ObjectTrack(0, default_shape("sphere"), np.arange(5), np.zeros((5, 3)), np.zeros(5), np.ones(5, bool), np.ones(5))
    with pytest.raises(ValueError, match="beyond the video"):
        Observations((track,), num_frames=3)
