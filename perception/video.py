"""Reading videos (PyAV) and camera files for perception."""

from __future__ import annotations

import math
from pathlib import Path

import av
import numpy as np


def read_video(path: str | Path, *, max_frames: int | None = None) -> tuple[np.ndarray, float]:
    """Decode a video file to (F, H, W, 3) uint8 RGB frames and its frame rate (frames/s).

    Raises FileNotFoundError for a missing file and ValueError for a file that
    is not a decodable video or holds no frames.
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"no such video file: {path}")
    if path.is_dir():
        raise ValueError(f"video: {path} is a directory, expected a video file")
    frames = []
    try:
        with av.open(str(path)) as container:
            if not container.streams.video:
                raise ValueError(f"video: {path} has no video stream")
            stream = container.streams.video[0]
            stream.thread_type = "AUTO"  # frame-parallel decoding: less wall time on a multi-core machine, same output
            rate = float(stream.average_rate) if stream.average_rate else 25.0
            for frame in container.decode(video=0):
                frames.append(frame.to_ndarray(format="rgb24"))
                if max_frames is not None and len(frames) >= max_frames:
                    break
    except (av.error.FFmpegError, UnicodeDecodeError) as error:  # PyAV's base error for undecodable input
        raise ValueError(f"video: {path} is not a readable video ({type(error).__name__}: {error})") from None
    if not frames:
        raise ValueError(f"video: {path} holds no frames")
    return np.stack(frames), (rate if math.isfinite(rate) and rate > 0 else 25.0)
