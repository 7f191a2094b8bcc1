"""Overlay, top-down pictures, diverging events, mp4 encoding and `physmind render`."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
from PIL import Image

from render.compose import BEYOND_DIM, Labelled, Overlay, SideBySide, comparison, png_bytes
from render.scene import TopDownView, diverging_events
from render.style import COLOR_RGB
from render.video import encode_mp4, read_video
from physmind.cli import main
from world.camera import footprint_outline, project
from world.io import world_to_dict
from world.rollout import default_horizon, simulate
from world.types import Edit, Event


def _count_colour(image: np.ndarray, rgb: tuple[int, int, int], tolerance: int = 12) -> int:
    return int((np.abs(image.astype(int) - np.array(rgb)).max(axis=-1) <= tolerance).sum())


@pytest.fixture(scope="module")
def base(seven_world):
    return simulate(seven_world, (), horizon_frames=default_horizon(seven_world), rollout_id="base")


@pytest.fixture(scope="module")
def without_red(seven_world):
    return simulate(seven_world, (Edit("remove_object", 0),), horizon_frames=default_horizon(seven_world), rollout_id="r-1")


def test_overlay_outlines_lie_on_the_projected_footprint(seven_world, base):
    camera = seven_world.camera
    video = np.zeros((20, camera.height, camera.width, 3), dtype=np.uint8)
    image = Overlay(seven_world, base, video).image(10)
    column = base.body_ids.index(0)
    outline = project(camera, footprint_outline(seven_world.body(0).shape, base.positions[10:11, column], base.yaw[10:11, column])[0, 1:])
    red = np.array(COLOR_RGB["red"])
    hits = 0
    for u, v in np.round(outline).astype(int):
        patch = image[max(v - 1, 0): v + 2, max(u - 1, 0): u + 2].reshape(-1, 3).astype(int)
        hits += bool((np.abs(patch - red).max(axis=-1) <= 12).any())
    assert hits >= 6, f"only {hits} of 8 outline points of body 0 are drawn in red"


def test_overlay_leaves_out_removed_bodies(seven_world, base, without_red):
    camera = seven_world.camera
    video = np.zeros((20, camera.height, camera.width, 3), dtype=np.uint8)
    assert _count_colour(Overlay(seven_world, base, video).image(5), COLOR_RGB["red"]) > 20
    assert _count_colour(Overlay(seven_world, without_red, video).image(5), COLOR_RGB["red"]) == 0


def test_overlay_past_the_video_end_draws_on_the_dimmed_last_frame(seven_world, base):
    camera = seven_world.camera
    video = np.full((10, camera.height, camera.width, 3), 200, dtype=np.uint8)
    overlay = Overlay(seven_world, base, video)
    inside, beyond = overlay.image(5), overlay.image(12)
    corner = (slice(camera.height - 6, camera.height), slice(camera.width - 6, camera.width))
    assert np.all(inside[corner] == 200)
    assert np.all(beyond[corner] == int(200 * BEYOND_DIM))
    assert np.all(video == 200), "the source video must not be drawn on"


def test_overlay_needs_a_camera_of_the_video_size(seven_world, base):
    with pytest.raises(ValueError, match="no camera"):
        Overlay(replace(seven_world, camera=None), base, np.zeros((2, 320, 480, 3), np.uint8))
    with pytest.raises(ValueError, match="camera is 480x320"):
        Overlay(seven_world, base, np.zeros((2, 100, 100, 3), np.uint8))


def test_topdown_view_axes():
    view = TopDownView(-1.0, 3.0, 0.0, 2.0, 400, 200)
    assert np.allclose(view.to_pixels(np.array([1.0, 1.0])), [200, 100])
    right, up = view.to_pixels(np.array([[2.0, 1.0], [1.0, 1.5]]))
    assert right[0] > 200 and np.isclose(right[1], 100)
    assert up[1] < 100 and np.isclose(up[0], 200)


def test_side_by_side_draws_every_active_body_and_omits_removed(seven_world, base, without_red):
    board = comparison(seven_world, base, without_red, 320, 240)
    image = np.asarray(board.image())
    assert image.shape == (board.height, 640, 3)
    left, right = image[:240, :320], image[:240, 320:]
    for body in seven_world.bodies:
        assert _count_colour(left, COLOR_RGB[body.color]) > 10, f"body {body.id} ({body.color}) missing on the factual panel"
    assert _count_colour(right, COLOR_RGB["red"]) == 0
    assert _count_colour(right, COLOR_RGB["cyan"]) > 10


def test_diverging_events_match_kind_objects_and_nearby_frames():
    def collision(a, b, frame):
        return Event("collision", (a, b), frame / 25.0, frame)

    reference = (collision(0, 1, 10), collision(1, 2, 30), collision(3, 4, 50))
    edited = (collision(1, 0, 13), collision(1, 2, 40), collision(2, 3, 60))
    ref_flags, edit_flags = diverging_events(reference, edited, tolerance_frames=5)
    assert ref_flags == (False, True, True)
    assert edit_flags == (False, True, True)


def test_encode_mp4_round_trip(tmp_path):
    frames = [np.full((64, 96, 3), 40 * k, dtype=np.uint8) for k in range(5)]
    path = tmp_path / "x.mp4"
    path.write_bytes(encode_mp4(iter(frames), 25.0))
    decoded, fps = read_video(str(path))
    assert decoded.shape == (5, 64, 96, 3) and fps == pytest.approx(25.0)
    assert np.abs(decoded[4].astype(int) - 160).max() < 8
    with pytest.raises(ValueError, match="no frames"):
        encode_mp4(iter([]), 25.0)


def test_png_bytes_decodes(seven_world, base):
    data = png_bytes(SideBySide(seven_world, [Labelled("factual", base)], 200, 150).image(3))
    assert Image.open(__import__("io").BytesIO(data)).size == (200, 150 + 34 + 26)


def test_cli_render_still_edit_video_and_errors(seven_world, tmp_path, capsys):
    world_path = tmp_path / "world.json"
    world_path.write_text(json.dumps(world_to_dict(replace(seven_world, observed_frames=20))))
    still = tmp_path / "still.png"
    assert main(["render", str(world_path), "-o", str(still)]) == 0
    assert still.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    replay = tmp_path / "cf.mp4"
    edit = json.dumps({"edit_type": "remove_object", "object_id": 3})
    assert main(["render", str(world_path), "--edit", edit, "-o", str(replay)]) == 0
    frames, _ = read_video(str(replay))
    assert frames.shape[0] == default_horizon(replace(seven_world, observed_frames=20))
    capsys.readouterr()
    assert main(["render", str(world_path), "-o", str(tmp_path / "x.gif")]) == 2
    assert main(["render", str(world_path), "--edit", '{"edit_type": "remove_object", "object_id": 42}', "-o", str(still)]) == 2
    assert main(["render", str(tmp_path / "missing.json"), "-o", str(still)]) == 2
    errors = capsys.readouterr().err
    assert "suffix must be one of" in errors and "object_not_found" in errors and "no such world file" in errors
    assert "Traceback" not in errors


def test_cli_overlay_frame(seven_world, tmp_path):
    world_path = tmp_path / "world.json"
    world_path.write_text(json.dumps(world_to_dict(replace(seven_world, observed_frames=8))))
    camera = seven_world.camera
    video_path = tmp_path / "in.mp4"
    video_path.write_bytes(encode_mp4((np.full((camera.height, camera.width, 3), 90, np.uint8) for _ in range(8)), 25.0))
    out = tmp_path / "overlay.png"
    assert main(["render", str(world_path), "--video", str(video_path), "--frame", "9", "-o", str(out)]) == 0
    image = np.asarray(Image.open(out).convert("RGB"))
    assert image.shape == (camera.height, camera.width, 3)
    assert _count_colour(image, COLOR_RGB["red"]) > 20
