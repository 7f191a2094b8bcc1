"""The generator's h264 encoder is deterministic: the same frames give the same bytes on every run.

x264's assembly routines read memory their caller never set, so with them one process encoding one video
twice, decoding another in between, got two different videos; tests judging perception on painted videos
then flaked from run to run (synth.render.write_mp4 encodes without them).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from synth.render import read_mp4, write_mp4

FIXTURE_VIDEO = Path(__file__).resolve().parents[1] / "data" / "synth" / "videos" / "video_00001.mp4"


def _frames() -> np.ndarray:
    """(24, 320, 480, 3) uint8: a moving bright square on a noisy gradient (motion and grain for the encoder)."""
    rng = np.random.default_rng(0)
    v, u = np.mgrid[0:320, 0:480]
    frames = []
    for f in range(24):
        image = np.stack([u * 0.4, v * 0.6, (u + v) * 0.2], axis=-1) + rng.normal(0, 2.0, (320, 480, 3))
        image[100:160, 40 + 8 * f:100 + 8 * f] = (220, 60, 40)
        frames.append(np.clip(image, 0, 255).astype(np.uint8))
    return np.stack(frames)


def test_the_same_frames_give_the_same_bytes_with_other_decoding_in_between(tmp_path):
    frames = _frames()
    contents = []
    for k in range(3):
        path = tmp_path / f"video_{k}.mp4"
        write_mp4(path, frames, 25.0, crf=23)
        contents.append(path.read_bytes())
        read_mp4(FIXTURE_VIDEO)  # leaves the decoder's buffers behind in this process's memory
    assert contents[0] == contents[1] == contents[2], [len(c) for c in contents]
    decoded = read_mp4(tmp_path / "video_0.mp4")
    assert decoded.shape == frames.shape and np.abs(decoded.astype(int) - frames.astype(int)).mean() < 3.0
