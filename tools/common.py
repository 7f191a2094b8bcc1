"""Helpers shared by the tools: records, frame ranges, pair contact evidence.

Records are plain JSON-ready dicts; floats are rounded to micrometres /
microseconds so answers stay small and stable across JSON round trips.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from world.types import Event, Rollout, World

from tools.errors import invalid_argument
from tools.footprint import footprint_gap
from tools.session import BASE_ROLLOUT_ID

DECIMALS = 6
MOVING_SPEED = 1e-3  # m/s: below this a body counts as at rest
DEFAULT_CONTACT_TOLERANCE = 1e-3  # m: footprint gap that counts as touching in the conservative scan
DEFAULT_FRAME_TOLERANCE = 5  # frames: edited vs base agreement window (paper, App. A.3)


def r(value: float) -> float:
    return round(float(value), DECIMALS)


def vec(values: Any) -> list[float]:
    return [round(float(v), DECIMALS) for v in values]


def column(rollout: Rollout, object_id: int) -> int | None:
    """Axis index of ``object_id`` in the rollout arrays, None if the rollout does not hold it."""
    try:
        return rollout.body_ids.index(object_id)
    except ValueError:
        return None


def boundaries(rollout: Rollout) -> dict[str, Any]:
    return {
        "observed_frames": int(rollout.observed_frames),
        "horizon_frames": int(rollout.horizon_frames),
        "fps": float(rollout.fps),
        "last_frame": int(rollout.horizon_frames) - 1,
    }


def frame_range(args: Mapping[str, Any], rollout: Rollout, tool: str) -> tuple[int, int]:
    """Inclusive (start, end) from optional ``frame_start``/``frame_end``, clipped to the rollout.

    The end may exceed the horizon (clipped); a start after the end the client
    gave is an error. A start beyond the horizon is an empty range (start > end).
    """
    last = rollout.horizon_frames - 1
    start = int(args.get("frame_start", 0))
    given_end = args.get("frame_end")
    if given_end is not None and int(given_end) < start:
        raise invalid_argument(tool, "/frame_end", f"frame_end ({int(given_end)}) is before frame_start ({start})",
                               f"an integer >= {start}")
    return start, last if given_end is None else min(int(given_end), last)


def object_attributes(world: World, object_id: int) -> dict[str, Any]:
    body = world.body(object_id)
    return {"shape": body.shape.kind, "color": body.color, "material": body.material}


def object_record(rollout: Rollout, col: int, frame: int, object_id: int) -> dict[str, Any]:
    """One body's state at one frame of a rollout."""
    velocity = rollout.velocities[frame, col]
    speed = float(np.linalg.norm(velocity))
    return {
        "object_id": int(object_id),
        "frame": int(frame),
        "time": r(rollout.times[frame]),
        "position": vec(rollout.positions[frame, col]),
        "velocity": vec(velocity),
        "speed": r(speed),
        "yaw": r(rollout.yaw[frame, col]),
        "visible": bool(rollout.visible[frame, col]),
        "moving": speed > MOVING_SPEED,
    }


def event_record(event: Event, observed_frames: int) -> dict[str, Any]:
    return {
        "kind": event.kind,
        "objects": [int(b) for b in event.bodies],
        "frame": int(event.frame),
        "time": r(event.time),
        "position": vec(event.position),
        "impulse": r(event.impulse),
        "beyond_video": int(event.frame) >= observed_frames,
    }


def _number(value: Any) -> float | None:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
        return None
    return float(value)


def fit_error(world: World) -> dict[str, Any] | None:
    """The identification error recorded in the world's provenance, None for hand-made worlds.

    ``physmind fit`` stores its report under ``provenance["fit"]`` (``rmse`` in
    metres over observed frames, per-object ``objects[{id, rmse, observed_frames}]``);
    scalar entries are passed through, per-object errors become ``objects``.
    Provenance is free-form, so anything unexpected is skipped, never an error.
    """
    provenance = dict(world.provenance or {})
    for key in ("fit", "fit_error", "fit_report"):
        value = provenance.get(key)
        if isinstance(value, Mapping):
            out: dict[str, Any] = {
                str(k): v for k, v in value.items()
                if (isinstance(v, (str, bool)) or v is None or _number(v) is not None)
            }
            objects = value.get("objects")
            if isinstance(objects, list):
                out["objects"] = [
                    {"object_id": int(o["id"]), "rmse": _number(o.get("rmse")),
                     "observed_frames": int(o["observed_frames"]) if isinstance(o.get("observed_frames"), int) else None}
                    for o in objects
                    if isinstance(o, Mapping) and isinstance(o.get("id"), int) and not isinstance(o.get("id"), bool)
                ]
            return out
        if _number(value) is not None:
            return {"rmse": _number(value)}
    for key in ("rmse", "position_rmse", "rmse_m"):
        if _number(provenance.get(key)) is not None:
            return {"rmse": _number(provenance[key])}
    return None


@dataclass(frozen=True)
class PairEvidence:
    """How two objects touch in a rollout within an inclusive frame range.

    evidence: "collision_event" (the engine emitted collisions), "footprint_scan"
    (no event, but footprints touch within tolerance), or "none".
    frames: event frames, or for the scan the first frame of each touching run.
    touching_frames: every frame that matched (events: same as frames).
    nearest_distance: smallest footprint gap (m) over frames where both exist, None if never both.
    """

    evidence: str
    frames: tuple[int, ...]
    touching_frames: tuple[int, ...]
    events: tuple[dict[str, Any], ...]
    nearest_distance: float | None
    nearest_frame: int | None
    frames_both_present: int


def pair_evidence(world: World, rollout: Rollout, a: int, b: int, start: int, end: int, tolerance: float) -> PairEvidence:
    pair = tuple(sorted((a, b)))
    collisions = [
        e for e in rollout.events
        if e.kind == "collision" and tuple(sorted(e.bodies)) == pair and start <= e.frame <= end
    ]
    col_a, col_b = column(rollout, a), column(rollout, b)
    nearest, nearest_frame, both_count = None, None, 0
    touching: tuple[int, ...] = ()
    if col_a is not None and col_b is not None and start <= end:
        frames = np.arange(start, end + 1)
        both = rollout.active[start:end + 1, col_a] & rollout.active[start:end + 1, col_b]
        both_count = int(both.sum())
        if both_count:
            frames = frames[both]
            gaps = footprint_gap(
                world.body(a).shape, rollout.positions[frames, col_a], rollout.yaw[frames, col_a],
                world.body(b).shape, rollout.positions[frames, col_b], rollout.yaw[frames, col_b],
            )
            k = int(np.argmin(gaps))
            nearest, nearest_frame = r(max(float(gaps[k]), 0.0)), int(frames[k])
            touching = tuple(int(f) for f in frames[gaps <= tolerance])
    if collisions:
        records = tuple(event_record(e, rollout.observed_frames) for e in collisions)
        event_frames = tuple(int(e.frame) for e in collisions)
        return PairEvidence("collision_event", event_frames, event_frames, records, nearest, nearest_frame, both_count)
    if touching:
        run_starts = tuple(f for i, f in enumerate(touching) if i == 0 or touching[i - 1] != f - 1)
        records = tuple(
            {
                "kind": "contact", "objects": list(pair), "frame": f, "time": r(rollout.times[f]),
                "position": vec((rollout.positions[f, col_a] + rollout.positions[f, col_b]) / 2),
                "impulse": 0.0, "beyond_video": f >= rollout.observed_frames,
            }
            for f in run_starts
        )
        return PairEvidence("footprint_scan", run_starts, touching, records, nearest, nearest_frame, both_count)
    return PairEvidence("none", (), (), (), nearest, nearest_frame, both_count)


def check_pair(session: Any, args: Mapping[str, Any], tool: str) -> tuple[int, int]:
    a = session.check_object(args["object_a"], tool=tool, pointer="/object_a")
    b = session.check_object(args["object_b"], tool=tool, pointer="/object_b")
    if a == b:
        raise invalid_argument(tool, "/object_b", f"object_b must differ from object_a (both {a})", f"an object id other than {a}")
    return a, b


@dataclass(frozen=True)
class PairQuery:
    """The common arguments of the pair tools, checked and resolved."""

    a: int
    b: int
    rollout_id: str
    rollout: Rollout
    start: int
    end: int
    evidence: PairEvidence


def pair_query(session: Any, args: Mapping[str, Any], tool: str) -> PairQuery:
    """Check objects, rollout and frame range of check_contact / get_event_time, and gather the pair's evidence."""
    a, b = check_pair(session, args, tool)
    rollout_id = args.get("rollout_id", BASE_ROLLOUT_ID)
    rollout = session.rollout(rollout_id, tool=tool)
    start, end = frame_range(args, rollout, tool)
    tolerance = float(args.get("contact_tolerance", DEFAULT_CONTACT_TOLERANCE))
    return PairQuery(a, b, rollout_id, rollout, start, end, pair_evidence(session.world, rollout, a, b, start, end, tolerance))
