"""Perception on scenes generated in the test (a seed no tuning saw), in the default look and in a
held-out look (synth.looks "heldout": floor, light, shadows and camera never used while tuning
perception), checked against the generator's masks and truth."""

from __future__ import annotations

import json

import numpy as np
import pytest

from perception.pipeline import perceive_frames
from perception.video import read_video
from synth.generate import generate_scene
from tests.perception.coverage import whole_in_view_coverage
from world.io import load_camera

SEED = 902113  # used by no fixture, no benchmark and no tuning
MIN_WHOLE_FRAMES = 10  # objects whole in view at least this often must be found


@pytest.fixture(scope="module", params=["default", "heldout"])
def unseen_scene(tmp_path_factory, request):
    root = tmp_path_factory.mktemp(request.param)
    generate_scene(root, SEED, 0, looks=request.param)
    camera = load_camera(root / "ground_truth" / "scene_00000.json")
    frames, fps = read_video(root / "videos" / "video_00000.mp4")
    observations, inter = perceive_frames(frames, camera, fps=fps)
    masks = json.loads((root / "masks" / "proposal_00000.json").read_text())["frames"]
    annotation = json.loads((root / "annotations" / "annotation_00000.json").read_text())
    return camera, observations, inter["lifted"], masks, annotation


def _covering(camera, lifted, masks) -> dict[int, list[int]]:
    """true object id -> perceived id per frame where the object is whole in view (-1: no track with mask IoU >= 0.5)."""
    covering = whole_in_view_coverage(camera, lifted, masks)
    return {k: [pid for _, pid in seq] for k, seq in covering.items() if len(seq) >= MIN_WHOLE_FRAMES}


@pytest.mark.slow
def test_unseen_scene_objects_found_once_with_their_colour(unseen_scene):
    camera, observations, lifted, masks, annotation = unseen_scene
    covering = _covering(camera, lifted, masks)
    assert covering, "the generated scene has objects whole in view"
    truth = {o["object_id"]: o for o in annotation["object_property"]}
    owners = []
    for object_id, seq in covering.items():
        found = [p for p in seq if p >= 0]
        assert len(found) >= 0.9 * len(seq), f"object {object_id} found in {len(found)}/{len(seq)} whole-in-view frames"
        assert len(set(found)) == 1, f"object {object_id} carried by ids {sorted(set(found))} (identity switch)"
        owners.append(found[0])
        assert observations.object(found[0]).color == truth[object_id]["color"], f"object {object_id}"
    assert len(set(owners)) == len(owners), "two objects share one track"


@pytest.mark.slow
def test_unseen_scene_lifting_within_two_centimetres(unseen_scene):
    camera, observations, lifted, masks, annotation = unseen_scene
    truth = {(e["frame_id"], o["object_id"]): np.asarray(o["location"]) for e in annotation["motion_trajectory"] for o in e["objects"]}
    errors = []
    for object_id, seq in _covering(camera, lifted, masks).items():
        track = observations.object(max(set(seq) - {-1}, key=seq.count))
        for frame, position, weight in zip(track.frames, track.positions, track.weights):
            if weight >= 0.5 and (int(frame), object_id) in truth:
                errors.append(np.linalg.norm(position[:2] - truth[(int(frame), object_id)][:2]))
    assert len(errors) > 100
    assert np.median(errors) <= 0.02, f"median lifting error {np.median(errors) * 100:.2f} cm"


@pytest.mark.slow
def test_unseen_scene_entry_and_exit_frames_within_two_frames(unseen_scene):
    camera, observations, lifted, masks, annotation = unseen_scene
    num_frames = observations.num_frames
    in_view: dict[int, np.ndarray] = {}
    for entry in annotation["motion_trajectory"]:
        for o in entry["objects"]:
            if entry["frame_id"] < num_frames:
                in_view.setdefault(o["object_id"], np.zeros(num_frames, bool))[entry["frame_id"]] = o["inside_camera_view"]
    events = 0
    for object_id, seq in _covering(camera, lifted, masks).items():
        track = observations.object(max(set(seq) - {-1}, key=seq.count))
        ours = np.zeros(num_frames, bool)
        ours[track.frames[track.visible]] = True
        truth = in_view[object_id]
        for true_frame, our_frame in ((np.argmax(truth), np.argmax(ours)), (num_frames - np.argmax(truth[::-1]), num_frames - np.argmax(ours[::-1]))):
            if 0 < true_frame < num_frames:
                events += 1
                assert abs(int(our_frame) - int(true_frame)) <= 2, f"object {object_id}: perceived {our_frame}, true {true_frame}"
    assert events, "the generated scene has an object entering or leaving the view"
