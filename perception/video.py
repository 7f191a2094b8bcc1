"""Reading videos (PyAV) and camera files for perception."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from world.types import Camera


def read_video(path: str | Path, *, max_frames: int | None = None) -> tuple[np.ndarray, float]:
    """Decode a video file to (F, H, W, 3) uint8 RGB frames and its frame rate (frames/s).

    Raises FileNotFoundError for a missing file and ValueError for a file that
    is not a decodable video or holds no frames.
    """
    import av

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


_CAMERA_NUMBERS = ("fx", "fy", "cx", "cy")


def camera_from_mapping(document: Mapping[str, Any], where: str = "camera") -> Camera:
    """A world.types.Camera from a bare camera object or a generator ground-truth file (key ``camera``).

    Fields (OpenCV convention): width, height (pixels), fx, fy, cx, cy (pixels),
    position [x, y, z] (m), rotation 3x3 row-major camera-to-world.
    """
    if not isinstance(document, Mapping):
        raise ValueError(f"{where}: expected a JSON object")
    if "camera" in document and isinstance(document["camera"], Mapping):
        document, where = document["camera"], f"{where}.camera"
    convention = document.get("convention", "opencv")
    if convention != "opencv":
        raise ValueError(f"{where}.convention: only 'opencv' is supported, got {convention!r}")
    for name in ("width", "height"):
        value = document.get(name)
        if not isinstance(value, int) or isinstance(value, bool) or value <= 0:
            raise ValueError(f"{where}.{name}: expected a positive integer, got {value!r}")
    for name in _CAMERA_NUMBERS:
        value = document.get(name)
        if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
            raise ValueError(f"{where}.{name}: expected a finite number, got {value!r}")
    position = document.get("position")
    if not (isinstance(position, list) and len(position) == 3 and all(isinstance(v, (int, float)) for v in position)):
        raise ValueError(f"{where}.position: expected [x, y, z] in metres, got {position!r}")
    rotation = document.get("rotation")
    if not (isinstance(rotation, list) and len(rotation) == 3 and all(isinstance(r, list) and len(r) == 3 for r in rotation)):
        raise ValueError(f"{where}.rotation: expected a 3x3 row-major matrix, got {rotation!r}")
    return Camera(
        width=int(document["width"]), height=int(document["height"]),
        fx=float(document["fx"]), fy=float(document["fy"]), cx=float(document["cx"]), cy=float(document["cy"]),
        position=tuple(float(v) for v in position), rotation=tuple(tuple(float(v) for v in row) for row in rotation),
    )


def load_camera(path: str | Path) -> Camera:
    """Read a camera JSON file (bare camera or ground-truth document with a ``camera`` key)."""
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"no such camera file: {path}")
    try:
        document = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as error:
        raise ValueError(f"camera file {path}: not valid JSON ({error})") from None
    return camera_from_mapping(document, where=f"camera file {path.name}")


def camera_to_mapping(camera: Camera) -> dict[str, Any]:
    return {"convention": "opencv", "width": int(camera.width), "height": int(camera.height),
            "fx": float(camera.fx), "fy": float(camera.fy), "cx": float(camera.cx), "cy": float(camera.cy),
            "position": [float(v) for v in camera.position], "rotation": [[float(v) for v in row] for row in camera.rotation]}
