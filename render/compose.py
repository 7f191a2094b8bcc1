"""Whole pictures: overlay frames over a video, side-by-side top-down frames and stills.

Everything here returns RGB arrays (H, W, 3) uint8 or PNG bytes; encoding to mp4 is ``render.video``.
"""

from __future__ import annotations

import io
from dataclasses import dataclass
from typing import Iterator, Sequence

import numpy as np
from PIL import Image

from world.types import Rollout, World

from render.draw import (
    draw_cursor, draw_overlay_frame, draw_timeline, draw_topdown, draw_topdown_background, project_rollout, topdown_rollout,
)
from render.scene import diverging_events, view_for

PANEL_WIDTH = 480
PANEL_HEIGHT = 360
TIMELINE_ROW = 26
TIMELINE_AXIS = 34
# Frames past the end of the video are drawn on its last frame, dimmed by this factor.
BEYOND_DIM = 0.55


@dataclass(frozen=True)
class Labelled:
    """A rollout with the title its panel and timeline row show."""

    label: str
    rollout: Rollout


class Overlay:
    """A rollout drawn through the world's camera over ``video`` (F, H, W, 3) uint8.

    Frames past the video's end reuse its last frame, dimmed. Raises ValueError when the world
    has no camera or the sizes disagree.
    """

    def __init__(self, world: World, rollout: Rollout, video: np.ndarray) -> None:
        camera = world.camera
        if camera is None:
            raise ValueError("the world has no camera; give one (--camera) to draw over the video")
        height, width = video.shape[1:3]
        if (width, height) != (camera.width, camera.height):
            raise ValueError(f"the video is {width}x{height} pixels but the camera is {camera.width}x{camera.height}")
        self.world, self.rollout, self.video, self.camera = world, rollout, video, camera
        self.projected = project_rollout(world, rollout, camera)
        self.horizon_frames = rollout.horizon_frames
        self._dimmed_last: np.ndarray | None = None

    def _source(self, frame: int) -> np.ndarray:
        last = self.video.shape[0] - 1
        if frame <= last:
            return self.video[frame]
        if self._dimmed_last is None:
            self._dimmed_last = (self.video[last].astype(np.float32) * BEYOND_DIM).astype(np.uint8)
        return self._dimmed_last

    def image(self, frame: int) -> np.ndarray:
        """The overlay at ``frame`` (0..horizon-1): (H, W, 3) uint8."""
        if not 0 <= frame < self.horizon_frames:
            raise ValueError(f"frame: expected 0..{self.horizon_frames - 1}, got {frame}")
        image = Image.fromarray(self._source(frame))  # copies, so the video stays untouched
        beyond = frame >= self.video.shape[0]
        draw_overlay_frame(image, self.world, self.rollout, self.projected, frame, self.camera, beyond)
        return np.asarray(image)

    def frames(self) -> Iterator[np.ndarray]:
        """One image per rollout frame 0..horizon-1."""
        for frame in range(self.horizon_frames):
            yield self.image(frame)


def _rows(rollouts: Sequence[Labelled]) -> list[tuple[str, Rollout, tuple[bool, ...]]]:
    """Timeline rows with diverging flags: the first rollout is the reference for the others."""
    if len(rollouts) == 1:
        return [(rollouts[0].label, rollouts[0].rollout, ())]
    reference = rollouts[0].rollout
    rows = []
    reference_flags: list[bool] = [False] * len(reference.events)
    for item in rollouts[1:]:
        ref_flags, flags = diverging_events(reference.events, item.rollout.events)
        reference_flags = [a or b for a, b in zip(reference_flags, ref_flags)]
        rows.append((item.label, item.rollout, flags))
    return [(rollouts[0].label, reference, tuple(reference_flags)), *rows]


class SideBySide:
    """Top-down panels of several rollouts of one world in one shared view, above an event timeline."""

    def __init__(self, world: World, rollouts: Sequence[Labelled], panel_width: int = PANEL_WIDTH,
                 panel_height: int = PANEL_HEIGHT) -> None:
        if not rollouts:
            raise ValueError("nothing to draw: no rollout")
        self.world = world
        self.rollouts = list(rollouts)
        self.view = view_for(world, [r.rollout for r in rollouts], panel_width, panel_height)
        self.rows = _rows(self.rollouts)
        self.drawn = [topdown_rollout(world, r.rollout, self.view) for r in rollouts]
        self.backgrounds = [draw_topdown_background(self.view, r.label) for r in rollouts]
        self.horizon_frames = max(r.rollout.horizon_frames for r in rollouts)
        self.fps = rollouts[0].rollout.fps
        self.width = panel_width * len(rollouts)
        self.timeline_height = TIMELINE_AXIS + TIMELINE_ROW * len(rollouts)
        self.height = panel_height + self.timeline_height
        self._timeline_box = (0, panel_height, self.width - 1, self.height - 1)
        self._blank: Image.Image | None = None
        self._timeline_x = None

    def image(self, frame: int | None = None) -> Image.Image:
        """The panels at ``frame`` (None: each rollout's last frame, full trails, no cursor)."""
        if self._blank is None:  # the timeline is the same on every frame: draw it once
            self._blank = Image.new("RGB", (self.width, self.height), (255, 255, 255))
            self._timeline_x = draw_timeline(self._blank, self._timeline_box, self.rows, self.horizon_frames, self.fps,
                                             self.rollouts[0].rollout.observed_frames)
        canvas = self._blank.copy()
        for k, (item, drawn, background) in enumerate(zip(self.rollouts, self.drawn, self.backgrounds)):
            panel = background.copy()
            last = item.rollout.horizon_frames - 1
            shown = last if frame is None else min(frame, last)
            draw_topdown(panel, self.world, item.rollout, drawn, shown, self.rows[k][2])
            canvas.paste(panel, (k * self.view.width, 0))
        if frame is not None:
            draw_cursor(canvas, self._timeline_box, self._timeline_x(frame))
        return canvas

    def frames(self) -> Iterator[np.ndarray]:
        """One image per frame 0..horizon-1, (height, width, 3) uint8."""
        for frame in range(self.horizon_frames):
            yield np.asarray(self.image(frame))


def png_bytes(image: Image.Image | np.ndarray) -> bytes:
    """Encode an image as PNG (fast zlib level: these are previews, not archives)."""
    if isinstance(image, np.ndarray):
        image = Image.fromarray(image)
    buffer = io.BytesIO()
    image.save(buffer, format="PNG", compress_level=3)
    return buffer.getvalue()


def edit_label(rollout: Rollout) -> str:
    """A short title for a rollout: "factual" or its edits, e.g. "remove_object 3; set_mass 1 2.0"."""
    if not rollout.edits:
        return "factual"
    parts = []
    for edit in rollout.edits:
        value = "" if edit.value is None else " " + (
            "(" + ", ".join(f"{v:g}" for v in edit.value) + ")" if isinstance(edit.value, tuple) else f"{edit.value:g}")
        parts.append(f"{edit.kind} {edit.body}{value}")
    return "edited: " + "; ".join(parts)


def comparison(world: World, reference: Rollout, edited: Rollout | None = None, panel_width: int = PANEL_WIDTH,
               panel_height: int = PANEL_HEIGHT) -> SideBySide:
    """One panel for ``reference`` alone, or factual and edited side by side (events diverging from the reference highlighted)."""
    items = [Labelled(edit_label(reference), reference)]
    if edited is not None and edited is not reference:
        items.append(Labelled(edit_label(edited), edited))
    return SideBySide(world, items, panel_width, panel_height)
