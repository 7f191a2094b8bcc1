"""Bad input (blank, static, truncated or object-less video, wrong camera) gives one clear error, never an empty world."""

from __future__ import annotations

import argparse
import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from perception.background import estimate_background
from perception.pipeline import perceive
from perception.video import read_video
from synth.render import write_mp4
from world.io import camera_from_dict, load_camera

DATA = Path(__file__).resolve().parents[1] / "data" / "synth"
TRUTH = DATA / "ground_truth" / "scene_00000.json"


@pytest.fixture(scope="module")
def floor_video(tmp_path_factory) -> Path:
    """16 frames of the fixture's floor (its smooth floor model) with sensor-like noise, no objects."""
    frames, _ = read_video(DATA / "videos" / "video_00001.mp4", max_frames=32)
    floor = estimate_background(frames).floor_fit
    rng = np.random.default_rng(0)
    video = np.clip(floor[None] + rng.normal(0, 1.5, (16,) + floor.shape), 0, 255).astype(np.uint8)
    path = tmp_path_factory.mktemp("floor") / "floor.mp4"
    write_mp4(path, video, 25.0)
    return path


def test_video_without_objects_is_a_clear_error(floor_video):
    with pytest.raises(ValueError, match="nothing moves"):
        perceive(floor_video, load_camera(TRUTH))


def test_black_video_is_a_clear_error(tmp_path):
    path = tmp_path / "black.mp4"
    write_mp4(path, np.zeros((12, 320, 480, 3), np.uint8), 25.0)
    with pytest.raises(ValueError, match="blank"):
        perceive(path, load_camera(TRUTH))


def test_small_objects_on_a_flat_floor_are_not_blank():
    # fresh held-out set 63636, scene 54: a flat grey floor without shadows, objects under 1 % of the pixels
    from perception.pipeline import check_frames

    rng = np.random.default_rng(3)
    frames = np.clip(183 + rng.normal(0, 1.0, (16, 320, 480, 3)), 0, 255).astype(np.uint8)
    for k, image in enumerate(frames):
        image[280:300, 100 + 8 * k:120 + 8 * k] = (225, 205, 40)  # a 20 px yellow object crossing the view
    check_frames(frames, load_camera(TRUTH))  # no error
    with pytest.raises(ValueError, match="blank"):
        check_frames(np.full_like(frames, 183), load_camera(TRUTH))


def test_static_video_with_objects_is_a_clear_error(tmp_path):
    frames, _ = read_video(DATA / "videos" / "video_00007.mp4", max_frames=1)
    path = tmp_path / "still.mp4"
    write_mp4(path, np.repeat(frames, 12, axis=0), 25.0)
    with pytest.raises(ValueError, match="nothing moves"):
        perceive(path, load_camera(TRUTH))


def test_truncated_video_is_a_clear_error(tmp_path):
    data = (DATA / "videos" / "video_00007.mp4").read_bytes()
    path = tmp_path / "truncated.mp4"
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(ValueError, match="video"):
        perceive(path, load_camera(TRUTH))


def test_camera_that_does_not_see_the_floor_is_a_clear_error():
    camera = load_camera(TRUTH)
    upside = replace(camera, rotation=tuple(tuple(-x for x in row) if k == 2 else row for k, row in enumerate(camera.rotation)))
    frames, _ = read_video(DATA / "videos" / "video_00007.mp4", max_frames=4)
    from perception.pipeline import check_frames

    with pytest.raises(ValueError, match="does not look down at the floor"):
        check_frames(frames, upside)


def test_cli_bad_input_is_one_line_and_exit_code_2(floor_video, tmp_path, capsys):
    from physmind.cli import main

    out = tmp_path / "obs.json"
    assert main(["perceive", str(floor_video), "--camera", str(TRUTH), "-o", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "nothing moves" in err and "Traceback" not in err
    assert not out.exists(), "no observations file for a video without objects"


@pytest.fixture(scope="module")
def short_clip(tmp_path_factory) -> Path:
    """The first 40 frames of fixture scene 7 (an unseen-by-tuning scene)."""
    frames, _ = read_video(DATA / "videos" / "video_00007.mp4", max_frames=40)
    path = tmp_path_factory.mktemp("clip") / "clip.mp4"
    write_mp4(path, frames, 25.0)
    return path


def test_cli_writes_observations_and_debug_sheet(short_clip, tmp_path):
    from perception.cli import register

    truth = DATA / "ground_truth" / "scene_00007.json"
    parser = argparse.ArgumentParser()
    register(parser.add_subparsers())
    out = tmp_path / "obs.json"
    args = parser.parse_args(["perceive", str(short_clip), "--camera", str(truth), "-o", str(out),
                              "--debug-dir", str(tmp_path / "dbg"), "--quiet"])
    assert args.handler(args) == 0
    document = json.loads(out.read_text())
    assert document["num_frames"] == 40 and document["camera"]["width"] == 480 and len(document["objects"]) >= 1
    assert (tmp_path / "dbg" / "contact_sheet.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize(
    "make, error, words",
    [
        (lambda d: d / "missing.mp4", FileNotFoundError, "no such video"),
        (lambda d: (d / "junk.mp4").write_bytes(b"not a video at all" * 50) and d / "junk.mp4", ValueError, "not a readable video"),
        (lambda d: (d / "empty.mp4").write_bytes(b"") == 0 and d / "empty.mp4", ValueError, "video"),
        (lambda d: d, ValueError, "directory"),
    ],
)
def test_bad_video_is_a_clear_error(tmp_path, make, error, words):
    with pytest.raises(error, match=words):
        perceive(make(tmp_path), load_camera(TRUTH))


def test_wrong_resolution_for_the_camera(floor_video):
    camera = replace(load_camera(TRUTH), width=640, cx=319.5)
    with pytest.raises(ValueError, match="640x320 does not match the video's 480x320"):
        perceive(floor_video, camera)


def test_missing_camera_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="no such camera file"):
        load_camera(tmp_path / "camera.json")


@pytest.mark.parametrize("field, value", [("fx", None), ("width", 0), ("position", [0, 1]), ("rotation", [[1, 0, 0]]), ("convention", "opengl")])
def test_bad_camera_field_is_named(field, value):
    document = json.loads(TRUTH.read_text())["camera"]
    document[field] = value
    with pytest.raises(ValueError, match=field):
        camera_from_dict(document)


def test_bare_camera_and_ground_truth_file_agree(tmp_path):
    bare = tmp_path / "camera.json"
    bare.write_text(json.dumps(json.loads(TRUTH.read_text())["camera"]))
    assert load_camera(bare) == load_camera(TRUTH)
