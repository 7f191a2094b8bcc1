"""End to end: `physmind synth` is deterministic and its files are complete and consistent."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from planner.program import execute
from physmind.cli import main
from synth.annotate import program_scene_from_ground_truth, seen_object_ids
from synth.render import read_mp4

REPO = Path(__file__).resolve().parents[2]


def _files(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*.json"))}


@pytest.mark.slow
def test_same_seed_gives_same_bytes_and_frames(tmp_path):
    # Two separate runs of the command, as a user makes them.
    first, second = tmp_path / "a", tmp_path / "b"
    for out in (first, second):
        command = [sys.executable, "-m", "physmind.cli", "synth", "--out", str(out), "--scenes", "1", "--seed", "3", "--start-index", "4"]
        completed = subprocess.run(command, cwd=REPO, capture_output=True, text=True, timeout=300)
        assert completed.returncode == 0, completed.stderr[-2000:]
    a, b = _files(first), _files(second)
    assert sorted(a) == ["annotations/annotation_00004.json", "ground_truth/scene_00004.json", "masks/proposal_00004.json", "questions.json"]
    assert a == b
    video = "videos/video_00004.mp4"
    assert (first / video).read_bytes() == (second / video).read_bytes()
    frames_a = read_mp4(first / video)
    assert frames_a.shape == (128, 320, 480, 3)
    # The video shows the scene: frames change over time and are not blank.
    assert frames_a.std() > 5 and np.abs(frames_a[0].astype(int) - frames_a[-1].astype(int)).max() > 50
    assert main(["synth", "contact-sheet", str(first), "--frames", "0,64,127", "--png", str(tmp_path / "sheet.png")]) == 0
    assert (tmp_path / "sheet.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    entries = json.loads((first / "questions.json").read_text())
    assert [e["scene_index"] for e in entries] == [4]
    # Questions name only objects seen in the video; the ground truth records the look.
    gt = json.loads((first / "ground_truth" / "scene_00004.json").read_text())
    scene, seen = program_scene_from_ground_truth(gt), seen_object_ids(gt)
    for question in entries[0]["questions"]:
        for program in [question["program"]] + [c["program"] for c in question["choices"]]:
            starts = [k for k, token in enumerate(program) if token == "objects"]
            for k in starts:
                end = program.index("unique", k)
                assert execute(program[k : end + 1], scene).id in seen
    assert gt["look"]["family"] == "default" and gt["look"]["crf"] == 18


@pytest.mark.parametrize(
    "argv, message",
    [
        (["synth", "--scenes", "1"], "--out"),
        (["synth", "--out", "x", "--scenes", "0"], "--scenes"),
        (["synth", "--out", "x", "--scenes", "1", "--workers", "0"], "--workers"),
        (["synth", "--out", "x", "--scenes", "1", "--start-index", "-1"], "--start-index"),
        (["synth", "contact-sheet", "/nonexistent/dir"], "no video"),
    ],
)
def test_cli_rejects_bad_arguments_with_one_line(argv, message, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
