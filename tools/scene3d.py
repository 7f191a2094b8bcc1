"""The tools on a 3D world (Physion++-style, ``world.scene3d``): session and the 3D side of four tools.

A 3D world has no edits: its rollouts are the factual continuation from the
anchor (the fitted state at the last observed frame) to a horizon, named
``base`` (the default horizon) and ``continue-<H>`` (continue_world). They are
a pure function of the world and the horizon, so every process of the server
recomputes them from the id (no rollout is stored). A rollout covers the
frames from the last observed one to its horizon; earlier frames hold no events.

check_contact, get_world_summary, list_events and continue_world answer on a
3D world (``run3d`` of their ToolSpec); every other tool answers 422
``not_available_in_3d`` (tools.registry.call_tool). Contact questions go
through ``world.scene3d.predict`` (the same query the eval used before the
tools served 3D worlds); the evidence names the fitted latent properties and
the contact time or the closest approach.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass, field
from typing import Any, ClassVar, Mapping

import numpy as np

from tools.common import frame_range, r, vec
from tools.errors import invalid_argument, not_found
from tools.session import BASE_ROLLOUT_ID, CONTINUATION_PREFIX, DEFAULT_MAX_HORIZON_FRAMES, continuation_id
from world.scene3d.motion import ZONE_TOUCH_TOLERANCE
from world.scene3d.predict import closest_approach, contact_query, default_horizon_frames, factual_rollout
from world.scene3d.rollout import Event3D, Rollout3D
from world.scene3d.types import World3D
from world.timebase import CONTACT_EPISODE_GAP_SECONDS, frame_of

WORLD3D_EVENT_KINDS = ("collision", "surface", "stop")  # what a 3D rollout emits (no camera: no in/out)
CACHED_ROLLOUTS = 16


@dataclass(frozen=True)
class Rollout3DView:
    """A factual 3D rollout under its tool id: ``horizon_frames`` frames counted from frame 0."""

    id: str
    horizon_frames: int
    rollout: Rollout3D


@dataclass
class World3DSession:
    """One 3D world and its factual continuations (computed on demand, cached in this process)."""

    world_id: str
    world: World3D
    max_horizon_frames: int = DEFAULT_MAX_HORIZON_FRAMES
    name: str | None = None
    is_3d: ClassVar[bool] = True
    _rollouts: dict[int, Rollout3D] = field(default_factory=dict, repr=False)
    _lock: threading.Lock = field(default_factory=threading.Lock, repr=False)

    @property
    def body_ids(self) -> list[int]:
        return [body.id for body in self.world.bodies]

    @property
    def zone_ids(self) -> list[int]:
        return [box.id for box in self.world.phases[-1].static_objects if box.role == "zone"]

    def default_horizon_frames(self) -> int:
        return default_horizon_frames(self.world)

    def rollout_ids(self) -> list[str]:
        with self._lock:
            computed = sorted(self._rollouts)
        default = self.default_horizon_frames()
        return [BASE_ROLLOUT_ID] + [continuation_id(h) for h in computed if h != default]

    def check_horizon(self, horizon_frames: int, *, tool: str | None, pointer: str) -> None:
        if horizon_frames > self.max_horizon_frames:
            raise invalid_argument(tool, pointer, f"horizon of {horizon_frames} frames exceeds this server's limit of "
                                   f"{self.max_horizon_frames}", f"<= {self.max_horizon_frames}")
        if horizon_frames < self.world.observed_frames:
            raise invalid_argument(tool, pointer, f"a continuation of {horizon_frames} frames ends before the last observed "
                                   f"frame ({self.world.observed_frames - 1})", f"an integer >= {self.world.observed_frames}")

    def continuation(self, horizon_frames: int, *, tool: str | None, pointer: str) -> Rollout3DView:
        """The factual continuation to ``horizon_frames`` (validated against the limits)."""
        self.check_horizon(horizon_frames, tool=tool, pointer=pointer)
        with self._lock:
            rollout = self._rollouts.get(horizon_frames)
        if rollout is None:
            rollout = factual_rollout(self.world, horizon_frames)
            with self._lock:
                if len(self._rollouts) >= CACHED_ROLLOUTS:
                    self._rollouts.pop(next(iter(self._rollouts)))
                self._rollouts[horizon_frames] = rollout
        default = self.default_horizon_frames()
        return Rollout3DView(BASE_ROLLOUT_ID if horizon_frames == default else continuation_id(horizon_frames),
                             horizon_frames, rollout)

    def rollout(self, rollout_id: str, *, tool: str | None, pointer: str = "/rollout_id") -> Rollout3DView:
        """``base`` or ``continue-<H>``; 404 listing the ids otherwise."""
        if rollout_id == BASE_ROLLOUT_ID:
            return self.continuation(self.default_horizon_frames(), tool=tool, pointer=pointer)
        suffix = rollout_id[len(CONTINUATION_PREFIX):] if rollout_id.startswith(CONTINUATION_PREFIX) else ""
        if not suffix.isdigit() or int(suffix) < 1:
            raise not_found("rollout", rollout_id, self.rollout_ids(), tool=tool, pointer=pointer)
        return self.continuation(int(suffix), tool=tool, pointer=pointer)

    def check_object(self, object_id: object, *, tool: str | None, pointer: str) -> int:
        """A body id of the world; 404 listing the body ids otherwise."""
        if object_id not in self.body_ids:
            raise not_found("object", object_id, self.body_ids, tool=tool, pointer=pointer)
        return int(object_id)  # type: ignore[arg-type]

    def check_target(self, object_id: object, *, tool: str | None, pointer: str) -> int:
        """A body id or a zone id of the last phase (a body id wins); 404 listing both otherwise."""
        if object_id not in self.body_ids and object_id not in self.zone_ids:
            raise not_found("object", object_id, self.body_ids + self.zone_ids, tool=tool, pointer=pointer)
        return int(object_id)  # type: ignore[arg-type]


# -- records ---------------------------------------------------------------------------


def boundaries3d(session: World3DSession, view: Rollout3DView) -> dict[str, Any]:
    return {"observed_frames": session.world.observed_frames, "horizon_frames": view.horizon_frames,
            "fps": float(session.world.fps), "last_frame": view.horizon_frames - 1}


def event3d_record(session: World3DSession, view: Rollout3DView, event: Event3D) -> dict[str, Any]:
    """An engine event in the tools' event format; ``static_object`` names the surface of an impact or the zone touched."""
    frame = frame_of(event.time, session.world.fps)
    bodies = [b for b in event.body_ids if b in session.body_ids]
    centres = [np.asarray(view.rollout.state(b, event.time).position) for b in bodies]
    record = {
        "kind": event.kind,
        "objects": sorted(int(b) for b in bodies) if event.kind == "collision" else [int(b) for b in bodies],
        "frame": frame, "time": r(event.time), "position": vec(np.mean(centres, axis=0)), "impulse": 0.0,
        "beyond_video": frame >= session.world.observed_frames,
    }
    if event.static_id is not None:
        record["static_object"] = int(event.static_id)
    return record


def reported_events(rollout: Rollout3D) -> list[Event3D]:
    """The rollout's events with one collision per contact episode of a pair (a pair collides anew only
    CONTACT_EPISODE_GAP_SECONDS after its previous touch, as in the 2D engine and CLEVRER)."""
    last_touch: dict[frozenset, float] = {}
    kept = []
    for event in rollout.events:
        if event.kind == "collision":
            pair = frozenset(event.body_ids)
            previous = last_touch.get(pair)
            last_touch[pair] = event.time
            if previous is not None and event.time - previous < CONTACT_EPISODE_GAP_SECONDS:
                continue
        kept.append(event)
    return kept


def fitted_records(world: World3D, object_ids: tuple[int, ...] | None = None) -> list[dict[str, Any]]:
    """The world's fitted properties (those of ``object_ids`` when given), as tool records."""
    return [{"kind": f.kind, "object_id": f.object_id, "other_object_id": f.other_object_id, "value": r(f.value),
             "std": r(f.std), "measurements": f.measurements}
            for f in world.fitted
            if object_ids is None or f.object_id in object_ids or f.other_object_id in object_ids]


# -- the four tools ---------------------------------------------------------------------


def check_contact3d(session: World3DSession, args: Mapping[str, Any], tool: str | None = None) -> dict[str, Any]:
    """Does object_a (a body) touch object_b (a body or a zone) in a factual continuation, within the range?"""
    a = session.check_object(args["object_a"], tool=tool, pointer="/object_a")
    b = session.check_target(args["object_b"], tool=tool, pointer="/object_b")
    if a == b:
        raise invalid_argument(tool, "/object_b", f"object_b must differ from object_a (both {a})", f"an object id other than {a}")
    rollout_id = args.get("rollout_id", BASE_ROLLOUT_ID)
    view = session.rollout(rollout_id, tool=tool)
    start, end = frame_range(args, view, tool)
    world = session.world
    zone = b not in session.body_ids
    first_continued = world.observed_frames - 1
    if zone and start > first_continued:
        raise invalid_argument(tool, "/frame_start", f"a zone target is searched from the last observed frame "
                               f"({first_continued}); frame_start {start} is later", f"an integer <= {first_continued}")
    if zone:  # the engine's contact query: the exact first touch of the patch
        outcome = contact_query(world, a, b, view.horizon_frames)
        touches = [e for e in outcome.rollout.events if e.kind == "contact"]
        searched = outcome.rollout
    else:  # the pair's collision roots in the continuation
        touches = [e for e in reported_events(view.rollout) if e.kind == "collision" and set(e.body_ids) == {a, b}]
        searched = view.rollout
    in_range = [e for e in touches if start <= frame_of(e.time, world.fps) <= end]
    records = [event3d_record(session, view, e) for e in in_range]
    if zone:
        for record in records:
            record["objects"] = [a]
    window = (max(world.start_time, start / world.fps), min(searched.end_time, end / world.fps))
    nearest, nearest_time = (closest_approach(world, searched, a, b, zone, window) if window[0] <= window[1]
                             else (None, None))
    first = records[0]["frame"] if records else None
    contact = bool(records)
    fitted = fitted_records(world, (a,) if zone else (a, b))
    properties = "; ".join(f["kind"] + f" of object {f['object_id']}"
                           + (f"/{f['other_object_id']}" if f["other_object_id"] is not None else "")
                           + f" = {f['value']:.3f} +- {f['std']:.3f}" for f in fitted) or "no fitted property"
    if contact:
        outcome_text = f"contact at t = {records[0]['time']:.3f} s (frame {first})"
    elif nearest is not None:
        outcome_text = f"no contact; closest approach {nearest:.3f} m at t = {nearest_time:.3f} s"
    else:
        outcome_text = "no contact; the range holds no continued frame"
    target = f"zone {b}" if zone else f"object {b}"
    return {
        "rollout_id": view.id,
        "objects": [a, b],
        "range": {"frame_start": start, "frame_end": end},
        "status": "contact" if contact and zone else "collision" if contact else "no_contact",
        "contact": contact,
        "evidence": "contact_root" if contact else "none",
        "matched_frames": [rec["frame"] for rec in records],
        "first_frame": first,
        "first_event": records[0] if records else None,
        "nearest_distance": None if nearest is None else r(nearest),
        "nearest_frame": None if nearest_time is None else frame_of(nearest_time, world.fps),
        "beyond_video": first is not None and first >= world.observed_frames,
        "observed_frames": world.observed_frames,
        "contact_tolerance": ZONE_TOUCH_TOLERANCE if zone else 0.0,
        "note": f"3D world: object {a} and {target} in the factual continuation from frame {first_continued}; "
                f"{properties}; {outcome_text}" + "".join(f"; {n}" for n in searched.notes),
        "base_comparison": None,
        "contact_time": records[0]["time"] if records else None,
        "nearest_time": None if nearest_time is None else r(nearest_time),
        "target_kind": "zone" if zone else "body",
        "fitted_properties": fitted,
    }


def get_world_summary3d(session: World3DSession, args: Mapping[str, Any], tool: str | None = None) -> dict[str, Any]:
    world = session.world
    first_states: dict[int, Any] = {}
    first_frames: dict[int, int] = {}
    for phase in world.phases:
        for body_id, state in phase.states:
            first_states.setdefault(body_id, state)
            first_frames.setdefault(body_id, frame_of(phase.start_time, world.fps))
    objects = []
    for body in world.bodies:
        state = first_states.get(body.id) or world.start_states.get(body.id)
        objects.append({
            "object_id": body.id, "shape": body.shape, "color": body.color, "material": None,
            "size": {"radius": r(body.half_size)} if body.shape == "sphere" else {"half_extent": r(body.half_size)},
            "mass": r(body.mass), "friction": r(body.friction), "restitution": r(body.restitution),
            "entry_frame": first_frames.get(body.id, world.observed_frames - 1), "exit_frame": None,
            "initial_position": vec(state.position) if state else [0.0, 0.0, 0.0],
            "initial_velocity": vec(state.velocity) if state else [0.0, 0.0, 0.0],
            "role": body.role, "impact_duration": r(body.impact_duration),
        })
    return {
        "world_id": session.world_id, "name": session.name or session.world_id, "fps": float(world.fps),
        "observed_frames": world.observed_frames, "default_horizon_frames": session.default_horizon_frames(),
        "gravity": float(world.gravity), "has_camera": False, "object_count": len(objects), "objects": objects,
        "rollout_ids": session.rollout_ids(), "fit_error": None,
        "world_format": "physmind.world3d/1",
        "phases": [{"start_time": r(p.start_time), "start_frame": frame_of(p.start_time, world.fps),
                    "static_objects": [{"id": s.id, "role": s.role, "center": vec(s.center), "half_extents": vec(s.half_extents),
                                        "orientation": [r(v) for v in s.orientation]} for s in p.static_objects]}
                   for p in world.phases],
        "patient_zone": world.patient_zone,
        "fitted_properties": fitted_records(world),
    }


def list_events3d(session: World3DSession, args: Mapping[str, Any], tool: str | None = None) -> dict[str, Any]:
    view = session.rollout(args.get("rollout_id", BASE_ROLLOUT_ID), tool=tool)
    start, end = frame_range(args, view, tool)
    object_id = args.get("object_id")
    if object_id is not None:
        object_id = session.check_object(object_id, tool=tool, pointer="/object_id")
    kinds = set(args.get("kinds") or WORLD3D_EVENT_KINDS)
    events = [record for record in (event3d_record(session, view, e) for e in reported_events(view.rollout) if e.kind in kinds)
              if start <= record["frame"] <= end and (object_id is None or object_id in record["objects"])]
    return {"rollout_id": view.id, "range": {"frame_start": start, "frame_end": end}, "count": len(events),
            "events": events, "boundaries": boundaries3d(session, view)}


def continue_world3d(session: World3DSession, args: Mapping[str, Any], tool: str | None = None) -> dict[str, Any]:
    view = session.continuation(int(args["horizon_frames"]), tool=tool, pointer="/horizon_frames")
    events = [event3d_record(session, view, e) for e in reported_events(view.rollout)]
    return {"rollout_id": view.id, "world_id": session.world_id, "anchored": session.world.anchor is not None,
            "boundaries": boundaries3d(session, view),
            "collisions": [e for e in events if e["kind"] == "collision"], "in_out_events": [],
            "surface_events": [e for e in events if e["kind"] == "surface"], "notes": list(view.rollout.notes)}
