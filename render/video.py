"""h264 mp4 encoding with PyAV (already a project dependency; OpenCV's wheel cannot encode h264)."""

from __future__ import annotations

import io
from fractions import Fraction
from typing import Iterable

import av
import numpy as np

# Fast x264 settings: these videos are for looking at, not ground truth (synth.render keeps
# its own slower, deterministic settings for generated datasets).
X264_OPTIONS = {"crf": "23", "preset": "veryfast"}


def encode_mp4(frames: Iterable[np.ndarray], fps: float) -> bytes:
    """Encode (H, W, 3) uint8 RGB frames as an h264 (yuv420p) mp4 and return its bytes.

    Odd widths or heights are cropped by one pixel (yuv420p needs even sizes).
    Raises ValueError when there is no frame.
    """
    buffer = io.BytesIO()
    count = 0
    with av.open(buffer, mode="w", format="mp4") as container:
        stream = None
        for image in frames:
            if stream is None:
                height, width = image.shape[0] // 2 * 2, image.shape[1] // 2 * 2
                stream = container.add_stream("libx264", rate=Fraction(fps).limit_denominator(1000))
                stream.width, stream.height, stream.pix_fmt = width, height, "yuv420p"
                stream.options = dict(X264_OPTIONS)
            frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(image[:height, :width]), format="rgb24")
            container.mux(stream.encode(frame))
            count += 1
        if stream is None:
            raise ValueError("no frames to encode")
        container.mux(stream.encode())
    return buffer.getvalue()


def read_video(path: str) -> tuple[np.ndarray, float]:
    """Decode a video file to (F, H, W, 3) uint8 RGB frames and its frame rate (frames/s)."""
    try:
        with av.open(str(path)) as container:
            stream = container.streams.video[0]
            fps = float(stream.average_rate or stream.base_rate or 25)
            frames = [frame.to_ndarray(format="rgb24") for frame in container.decode(video=0)]
    except (av.error.FFmpegError, IndexError) as error:
        raise ValueError(f"cannot read video {path}: {error}") from None
    if not frames:
        raise ValueError(f"video {path} has no frames")
    return np.stack(frames), fps
