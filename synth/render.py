"""Render a simulated scene with MuJoCo's offscreen renderer and write the video.

RGB frames come from the scene's camera ("main"); instance masks come from
MuJoCo's segmentation render of the same camera (geom ids mapped to object ids).
"""

from __future__ import annotations

import os
from fractions import Fraction
from pathlib import Path

import av
import numpy as np

os.environ.setdefault("MUJOCO_GL", "egl")  # headless rendering unless the user chose a backend

import mujoco  # noqa: E402  (after MUJOCO_GL)

from synth.scene import SceneSpec  # noqa: E402
from synth.simulate import SimResult, load_model  # noqa: E402


def render_scene(spec: SceneSpec, sim: SimResult, frames: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Render the first ``frames`` frames (default: the observed ones).

    Returns:
        rgb: (F, H, W, 3) uint8 images.
        instance: (F, H, W) int16 object id per pixel, -1 for floor/background.
    """
    count = spec.observed_frames if frames is None else int(frames)
    model, object_ids = load_model(spec)
    if tuple(object_ids) != tuple(sim.object_ids):
        raise ValueError("sim: the simulation result does not belong to this scene's full model")
    data = mujoco.MjData(model)
    height, width = spec.camera.height, spec.camera.width
    geom_to_object = np.full(model.ngeom + 1, -1, dtype=np.int16)
    for oid in object_ids:
        geom_to_object[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, f"geom{oid}")] = oid
    rgb = np.zeros((count, height, width, 3), dtype=np.uint8)
    instance = np.full((count, height, width), -1, dtype=np.int16)
    renderer = mujoco.Renderer(model, height=height, width=width)
    try:
        for frame in range(count):
            data.qpos[:] = sim.qpos[frame]
            mujoco.mj_forward(model, data)
            renderer.disable_segmentation_rendering()
            renderer.update_scene(data, camera="main")
            rgb[frame] = renderer.render()
            renderer.enable_segmentation_rendering()
            renderer.update_scene(data, camera="main")
            seg = renderer.render()
            ids, types = seg[..., 0], seg[..., 1]
            is_geom = (types == int(mujoco.mjtObj.mjOBJ_GEOM)) & (ids >= 0)
            instance[frame] = np.where(is_geom, geom_to_object[np.clip(ids, 0, model.ngeom)], -1)
    finally:
        renderer.close()
    return rgb, instance


def write_mp4(path: Path, frames: np.ndarray, fps: float, crf: int = 18) -> None:
    """Encode (F, H, W, 3) uint8 frames as h264 (yuv420p) with PyAV.

    Single-threaded x264 with fixed settings and without its assembly
    routines, so the same frames give the same video on every run and every
    machine: with them, one process encoding one painted video four times
    (decoding others in between) got four different videos, since x264's
    assembly reads memory its caller never set (about 4x the encoding time:
    2 s for 128 frames of 480 x 320). ``crf`` is x264's constant rate factor
    (higher = stronger compression; the default look uses 18).
    """
    path.parent.mkdir(parents=True, exist_ok=True)
    with av.open(str(path), mode="w") as container:
        stream = container.add_stream("libx264", rate=Fraction(fps).limit_denominator(1000))
        stream.width = frames.shape[2]
        stream.height = frames.shape[1]
        stream.pix_fmt = "yuv420p"
        stream.options = {"crf": str(int(crf)), "preset": "medium", "threads": "1", "x264-params": "asm=0"}
        stream.thread_count = 1
        for image in frames:
            packet = stream.encode(av.VideoFrame.from_ndarray(np.ascontiguousarray(image), format="rgb24"))
            container.mux(packet)
        container.mux(stream.encode())


def read_mp4(path: Path) -> np.ndarray:
    """Decode a video to (F, H, W, 3) uint8 RGB frames."""
    with av.open(str(path)) as container:
        return np.stack([frame.to_ndarray(format="rgb24") for frame in container.decode(video=0)])
