"""Pillow drawing primitives: one overlay frame, one top-down panel, the event timeline.

Coordinates are pixels (u right, v down). Pillow draws a frame of a few bodies in well under a
millisecond, which keeps a 128-frame overlay inside its time budget (docs/render.md).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from world.camera import footprint_outline, project
from world.types import Camera, Rollout, World

from render.scene import TopDownView
from render.style import (
    ARROW_SECONDS, BACKGROUND, COLLISION_COLOR, DIVERGING_COLOR, GRID, INK, MARKER_SECONDS, body_rgb,
)


@functools.lru_cache(maxsize=8)
def font(size: int) -> ImageFont.ImageFont:
    """Pillow's bundled font at ``size`` pixels (no system font needed)."""
    return ImageFont.load_default(size=size)


def _xy(points: np.ndarray) -> list[tuple[float, float]]:
    return [(float(u), float(v)) for u, v in points]


def _arrow(draw: ImageDraw.ImageDraw, start: np.ndarray, end: np.ndarray, color: tuple[int, int, int], width: int = 2) -> None:
    """A line from start to end (pixels) with a head at end; nothing for arrows under 3 px."""
    delta = end - start
    length = float(np.hypot(*delta))
    if not np.all(np.isfinite(delta)) or length < 3.0:
        return
    draw.line(_xy(np.stack([start, end])), fill=color, width=width)
    direction = delta / length
    normal = np.array([-direction[1], direction[0]])
    head = min(8.0, 0.4 * length)
    left, right = end - head * direction + 0.5 * head * normal, end - head * direction - 0.5 * head * normal
    draw.polygon(_xy(np.stack([end, left, right])), fill=color)


def _ring(draw: ImageDraw.ImageDraw, center: np.ndarray, radius: float, color: tuple[int, int, int], width: int = 3) -> None:
    u, v = float(center[0]), float(center[1])
    draw.ellipse((u - radius, v - radius, u + radius, v + radius), outline=color, width=width)


def _label(draw: ImageDraw.ImageDraw, at: tuple[float, float], text: str, size: int = 12,
           fill: tuple[int, int, int] = INK, box: tuple[int, int, int] | None = (255, 255, 255)) -> None:
    """Text with its top-left at ``at`` on a light box so it reads over any frame."""
    f = font(size)
    if box is not None:
        left, top, right, bottom = draw.textbbox(at, text, font=f)
        draw.rectangle((left - 2, top - 1, right + 2, bottom + 1), fill=box)
    draw.text(at, text, font=f, fill=fill)


# -- overlay through the camera -------------------------------------------------------
@dataclass(frozen=True)
class ProjectedRollout:
    """A rollout's bodies projected through a camera, for every frame.

    outline: (T, N, 8, 2) pixels of each footprint outline on the plane; centre: (T, N, 2)
    pixels of the footprint centre; arrow_tip: (T, N, 2) pixels of centre + velocity * ARROW_SECONDS
    on the plane; top: (T, N, 2) pixels of the body's top (label anchor). NaN behind the camera.
    """

    outline: np.ndarray
    centre: np.ndarray
    arrow_tip: np.ndarray
    top: np.ndarray


def project_rollout(world: World, rollout: Rollout, camera: Camera) -> ProjectedRollout:
    """Project every body of ``rollout`` at every frame (vectorised per body)."""
    frames, bodies = rollout.positions.shape[:2]
    outline = np.full((frames, bodies, 8, 2), np.nan)
    centre = np.full((frames, bodies, 2), np.nan)
    tip = np.full((frames, bodies, 2), np.nan)
    top = np.full((frames, bodies, 2), np.nan)
    for column, body_id in enumerate(rollout.body_ids):
        shape = world.body(body_id).shape
        positions, yaw = rollout.positions[:, column], rollout.yaw[:, column]
        outline[:, column] = project(camera, footprint_outline(shape, positions, yaw)[:, 1:])
        ground = positions * np.array([1.0, 1.0, 0.0])
        centre[:, column] = project(camera, ground)
        tip[:, column] = project(camera, ground + rollout.velocities[:, column] * np.array([1.0, 1.0, 0.0]) * ARROW_SECONDS)
        top[:, column] = project(camera, ground + np.array([0.0, 0.0, 2.0 * shape.rest_height]))
    return ProjectedRollout(outline, centre, tip, top)


def draw_overlay_frame(image: Image.Image, world: World, rollout: Rollout, projected: ProjectedRollout, frame: int,
                       camera: Camera, beyond_video: bool) -> Image.Image:
    """Draw the fitted world at ``frame`` over ``image`` (modified in place and returned).

    Each active body: its footprint outline in its colour, id and attributes, velocity arrow;
    collisions within MARKER_SECONDS of the frame: a ring at the contact point.
    """
    draw = ImageDraw.Draw(image)
    for column, body_id in enumerate(rollout.body_ids):
        if not rollout.active[frame, column]:
            continue
        body = world.body(body_id)
        color = body_rgb(body.color)
        polygon = projected.outline[frame, column]
        if np.all(np.isfinite(polygon)):
            draw.polygon(_xy(polygon), outline=color, width=2)
        _arrow(draw, projected.centre[frame, column], projected.arrow_tip[frame, column], color)
        anchor = projected.top[frame, column]
        if np.all(np.isfinite(anchor)):
            attributes = " ".join(v for v in (body.color, body.material, body.shape.kind) if v)
            _label(draw, (float(anchor[0]) - 10, float(anchor[1]) - 16), f"{body_id} {attributes}", size=11)
    window = MARKER_SECONDS * rollout.fps
    for event in rollout.events:
        if event.kind == "collision" and abs(event.frame - frame) <= window:
            pixel = project(camera, np.asarray(event.position, dtype=float) * np.array([1.0, 1.0, 0.0]))
            if np.all(np.isfinite(pixel)):
                _ring(draw, pixel, 12, COLLISION_COLOR)
    status = f"frame {frame}  t {frame / rollout.fps:.2f} s"
    if beyond_video:
        status += "  beyond the video: fitted continuation"
    _label(draw, (6, 4), status, size=12)
    return image


# -- top-down -------------------------------------------------------------------------
@dataclass(frozen=True)
class TopDownRollout:
    """A rollout in a top-down ``view``: outline (T, N, 8, 2), centre (T, N, 2), arrow_tip (T, N, 2) pixels."""

    view: TopDownView
    outline: np.ndarray
    centre: np.ndarray
    arrow_tip: np.ndarray


def topdown_rollout(world: World, rollout: Rollout, view: TopDownView) -> TopDownRollout:
    frames, bodies = rollout.positions.shape[:2]
    outline = np.empty((frames, bodies, 8, 2))
    for column, body_id in enumerate(rollout.body_ids):
        shape = world.body(body_id).shape
        outline[:, column] = view.to_pixels(footprint_outline(shape, rollout.positions[:, column], rollout.yaw[:, column])[:, 1:])
    centre = view.to_pixels(rollout.positions)
    tip = view.to_pixels(rollout.positions + rollout.velocities * ARROW_SECONDS)
    return TopDownRollout(view, outline, centre, tip)


def draw_topdown_background(view: TopDownView, title: str) -> Image.Image:
    """An empty panel: 1 m grid, the title at the top."""
    image = Image.new("RGB", (view.width, view.height), BACKGROUND)
    draw = ImageDraw.Draw(image)
    for x in range(math.floor(view.x_min) - 1, math.ceil(view.x_max) + 2):
        u = float(view.to_pixels(np.array([x, 0.0]))[0])
        draw.line(((u, 0), (u, view.height)), fill=GRID)
    for y in range(math.floor(view.y_min) - 1, math.ceil(view.y_max) + 2):
        v = float(view.to_pixels(np.array([0.0, y]))[1])
        draw.line(((0, v), (view.width, v)), fill=GRID)
    _label(draw, (6, 4), title, size=13, box=None)
    _label(draw, (6, view.height - 16), "1 m grid, top-down", size=10, box=None)
    return image


def draw_topdown(image: Image.Image, world: World, rollout: Rollout, drawn: TopDownRollout, frame: int,
                 diverging: Sequence[bool] = (), trail: bool = True) -> Image.Image:
    """Bodies of ``rollout`` at ``frame`` on a panel (in place): trails up to the frame, footprints,
    ids, velocity arrows; collisions so far as small crosses, recent ones (MARKER_SECONDS) as rings;
    diverging collisions (flags aligned with ``rollout.events``) in DIVERGING_COLOR."""
    draw = ImageDraw.Draw(image)
    for column, body_id in enumerate(rollout.body_ids):
        color = body_rgb(world.body(body_id).color)
        active = np.flatnonzero(rollout.active[: frame + 1, column])
        if trail and active.size > 1:
            draw.line(_xy(drawn.centre[active, column]), fill=color, width=1)
        if not rollout.active[frame, column]:
            continue
        draw.polygon(_xy(drawn.outline[frame, column]), fill=color, outline=INK)
        _arrow(draw, drawn.centre[frame, column], drawn.arrow_tip[frame, column], INK, width=1)
        u, v = drawn.centre[frame, column]
        _label(draw, (float(u) + 6, float(v) - 18), str(body_id), size=11, box=None)
    window = MARKER_SECONDS * rollout.fps
    for index, event in enumerate(rollout.events):
        if event.kind != "collision" or event.frame > frame:
            continue
        color = DIVERGING_COLOR if index < len(diverging) and diverging[index] else COLLISION_COLOR
        center = drawn.view.to_pixels(np.asarray(event.position, dtype=float))
        if frame - event.frame <= window:
            _ring(draw, center, 10, color)
        else:
            u, v = center
            draw.line(((u - 4, v - 4), (u + 4, v + 4)), fill=color, width=2)
            draw.line(((u - 4, v + 4), (u + 4, v - 4)), fill=color, width=2)
    return image


# -- event timeline -------------------------------------------------------------------
def draw_timeline(image: Image.Image, box: tuple[int, int, int, int], rows: Sequence[tuple[str, Rollout, Sequence[bool]]],
                  horizon_frames: int, fps: float, observed_frames: int, cursor: int | None = None) -> Callable[[float], float]:
    """A time axis across ``box`` (left, top, right, bottom pixels) with one row of events per rollout.

    rows: (label, rollout, diverging flags aligned with its events). Collisions are dots labelled
    "a-b", other events ticks labelled by the kind's initial (i(n), o(ut), s(top)); diverging events in DIVERGING_COLOR. A dashed line
    marks the end of the video; ``cursor`` (a frame) a red line (see ``draw_cursor``).
    Returns the map frame -> x pixel of the axis.
    """
    draw = ImageDraw.Draw(image)
    left, top, right, bottom = box
    label_width = 110
    x0, x1 = left + label_width, right - 8
    last = max(horizon_frames - 1, 1)

    def x_of(frame: float) -> float:
        return x0 + (x1 - x0) * frame / last

    draw.rectangle(box, fill=(255, 255, 255))
    axis_y = bottom - 18
    draw.line(((x0, axis_y), (x1, axis_y)), fill=INK)
    for second in range(0, int(last / fps) + 1):
        x = x_of(second * fps)
        draw.line(((x, axis_y), (x, axis_y + 4)), fill=INK)
        _label(draw, (x - 6, axis_y + 5), f"{second}s", size=10, box=None)
    video_end = x_of(min(observed_frames, last))
    for y in range(top + 2, axis_y, 6):
        draw.line(((video_end, y), (video_end, y + 3)), fill=(120, 120, 120))
    row_height = (axis_y - top - 4) / max(len(rows), 1)
    for r, (label, rollout, diverging) in enumerate(rows):
        y = top + 4 + row_height * (r + 0.5)
        _label(draw, (left + 4, y - 7), label, size=11, box=None)
        draw.line(((x0, y), (x1, y)), fill=GRID)
        for index, event in enumerate(rollout.events):
            flagged = index < len(diverging) and diverging[index]
            color = DIVERGING_COLOR if flagged else (COLLISION_COLOR if event.kind == "collision" else (110, 110, 110))
            x = x_of(event.frame)
            if event.kind == "collision":
                radius = 5 if flagged else 4
                draw.ellipse((x - radius, y - radius, x + radius, y + radius), fill=color)
                _label(draw, (x - 6, y - 17), "-".join(str(b) for b in event.bodies), size=9, fill=color, box=None)
            else:
                draw.line(((x, y - 5), (x, y + 5)), fill=color, width=2 if flagged else 1)
                _label(draw, (x - 3, y + 5), event.kind[0], size=9, fill=color, box=None)
    if cursor is not None:
        draw_cursor(image, box, x_of(cursor))
    return x_of


def draw_cursor(image: Image.Image, box: tuple[int, int, int, int], x: float) -> None:
    """The timeline's current-frame line at pixel column ``x`` inside ``box``."""
    ImageDraw.Draw(image).line(((x, box[1]), (x, box[3])), fill=(220, 0, 0), width=2)
