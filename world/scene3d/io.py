"""Read a Physion-layout annotation (docs/formats.md, "Physion layout") into 3D tracks.

The annotation lists, per observed frame, each object's 3D ``location`` and
``velocity``; curtain frames carry no objects; ``phases`` give each phase's
frames and static boxes.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Any, Mapping

import jsonschema
import numpy as np
from jsonschema.exceptions import best_match

from schemas import read_schema
from world.scene3d.types import (
    Anchor3D, Body3D, FittedProperty, Phase3D, PhaseTracks, State3D, StaticBox, Tracks3D, World3D,
)

DEFAULT_FPS = 25.0


@dataclass(frozen=True)
class AnnotationTiming:
    """fps; phase_frames: ((first, last), ...) observed frames per phase; boundary_frame: the last observed
    frame; horizon_frames: frames the question covers (None: not stated)."""

    fps: float
    phase_frames: tuple[tuple[int, int], ...]
    boundary_frame: int
    horizon_frames: int | None


def static_from_dict(document: Mapping[str, Any], where: str) -> StaticBox:
    try:
        return StaticBox(id=int(document["id"]), role=str(document["role"]), center=document["center"],
                         half_extents=document["half_extents"], orientation=document.get("orientation", (0, 0, 0, 1)),
                         kind=str(document.get("kind", "box")))
    except KeyError as error:
        raise ValueError(f"{where}: missing field {error.args[0]!r}") from None


def tracks_from_annotation(document: Mapping[str, Any]) -> tuple[Tracks3D, AnnotationTiming, dict[int, dict[int, State3D]]]:
    """Tracks per phase, the timing, and every observed state by frame: {frame: {object_id: State3D}}."""
    validate_physion(document, "annotation")
    fps = float(document.get("fps", DEFAULT_FPS))
    by_frame: dict[int, dict[int, State3D]] = {}
    missing_velocity: list[tuple[int, int]] = []
    for entry in document["motion_trajectory"]:
        states = {}
        for obj in entry.get("objects", []):
            object_id, frame = int(obj["object_id"]), int(entry["frame_id"])
            if obj.get("velocity") is None:
                missing_velocity.append((frame, object_id))
            states[object_id] = State3D(obj["location"], obj.get("velocity") or (0.0, 0.0, 0.0))
        by_frame[int(entry["frame_id"])] = states
    for frame, object_id in missing_velocity:  # finite differences over the neighbouring frames
        around = [f for f in (frame - 1, frame, frame + 1) if object_id in by_frame.get(f, {})]
        if len(around) >= 2:
            span = (around[-1] - around[0]) / fps
            velocity = (np.subtract(by_frame[around[-1]][object_id].position, by_frame[around[0]][object_id].position)) / span
            by_frame[frame][object_id] = State3D(by_frame[frame][object_id].position, velocity)
    if not by_frame:
        raise ValueError("annotation.motion_trajectory: no frames")
    bodies = []
    for k, prop in enumerate(document["object_property"]):
        object_id = int(prop["object_id"])
        shape = str(prop.get("shape", "cube"))
        if shape not in ("sphere", "cube"):
            raise ValueError(f"annotation.object_property[{k}].shape: {shape!r} is not supported in 3D (sphere or cube)")
        size = prop.get("size")
        if size is None:  # lowest observed centre height above the floor
            heights = [s[object_id].position[2] for s in by_frame.values() if object_id in s]
            size = float(np.clip(min(heights), 0.02, 1.0)) if heights else 0.1
        bodies.append(Body3D(object_id, shape, float(size), role=prop.get("role"), color=str(prop.get("color", "gray"))))
    phase_tracks, phase_frames = [], []
    for n, phase in enumerate(document["phases"]):
        first, last = (int(v) for v in phase["frames"])
        frames = [f for f in range(first, last + 1) if f in by_frame and by_frame[f]]
        if not frames:
            raise ValueError(f"annotation.phases[{n}]: no observed frames in {first}..{last}")
        ids = tuple(sorted({i for f in frames for i in by_frame[f]}))
        positions = np.full((len(frames), len(ids), 3), np.nan)
        velocities = np.full((len(frames), len(ids), 3), np.nan)
        for row, f in enumerate(frames):
            for col, object_id in enumerate(ids):
                if object_id in by_frame[f]:
                    positions[row, col] = by_frame[f][object_id].position
                    velocities[row, col] = by_frame[f][object_id].velocity
        statics = tuple(static_from_dict(box, f"annotation.phases[{n}].static_objects[{j}]")
                        for j, box in enumerate(phase.get("static_objects", [])))
        phase_tracks.append(PhaseTracks(np.asarray(frames) / fps, ids, positions, velocities, statics))
        phase_frames.append((frames[0], frames[-1]))
    boundary = int(document.get("prediction_boundary_frame", phase_frames[-1][1]))
    horizon = document.get("horizon_frames")
    tracks = Tracks3D(tuple(bodies), tuple(phase_tracks), document.get("patient_zone"))
    timing = AnnotationTiming(fps, tuple(phase_frames), boundary, None if horizon is None else int(horizon))
    return tracks, timing, by_frame


PHYSION_SCHEMA = "physion.schema.json"
WORLD3D_FORMAT = "physmind.world3d/1"


@lru_cache(maxsize=None)
def _physion_validator(definition: str):
    base = read_schema(PHYSION_SCHEMA)
    schema = {"$schema": base["$schema"], "$defs": base["$defs"], "$ref": f"#/$defs/{definition}"}
    jsonschema.Draft202012Validator.check_schema(schema)
    return jsonschema.Draft202012Validator(schema)


def validate_physion(document: object, definition: str) -> None:
    """Raise ValueError (with the JSON path) unless ``document`` follows physion.schema.json's
    ``definition`` (world3d, annotation or trials)."""

    errors = list(_physion_validator(definition).iter_errors(document))
    if errors:
        first = best_match(errors)
        where = "/".join(str(p) for p in first.absolute_path) or "(root)"
        raise ValueError(f"{definition} document invalid at {where}: {first.message}")


def static_to_dict(box: StaticBox) -> dict[str, Any]:
    return {"id": box.id, "kind": box.kind, "role": box.role, "center": list(box.center),
            "half_extents": list(box.half_extents), "orientation": list(box.orientation)}


def world3d_to_dict(world: World3D) -> dict[str, Any]:
    """A World3D as a JSON-ready document (physion.schema.json#/$defs/world3d); lossless."""
    return {
        "format": WORLD3D_FORMAT, "gravity": world.gravity,
        "bodies": [{"id": b.id, "shape": b.shape, "half_size": b.half_size, "mass": b.mass, "restitution": b.restitution,
                    "friction": b.friction, "impact_duration": b.impact_duration, "role": b.role, "color": b.color}
                   for b in world.bodies],
        "phases": [{"start_time": p.start_time, "static_objects": [static_to_dict(b) for b in p.static_objects],
                    "states": [{"object_id": i, "position": list(s.position), "velocity": list(s.velocity)} for i, s in p.states]}
                   for p in world.phases],
        "pair_restitution": [{"bodies": list(pair), "restitution": e} for pair, e in world.pair_restitution],
        "patient_zone": world.patient_zone, "provenance": dict(world.provenance),
        "fps": world.fps, "horizon_frames": world.horizon_frames,
        "anchor": None if world.anchor is None else {
            "time": world.anchor.time,
            "states": [{"object_id": i, "position": list(s.position), "velocity": list(s.velocity)} for i, s in world.anchor.states]},
        "fitted_properties": [{"kind": f.kind, "object_id": f.object_id, "other_object_id": f.other_object_id, "value": f.value,
                               "std": f.std, "measurements": f.measurements} for f in world.fitted],
    }


def world3d_from_dict(document: Mapping[str, Any]) -> World3D:
    validate_physion(document, "world3d")
    bodies = tuple(Body3D(b["id"], b["shape"], b["half_size"], b["mass"], b["restitution"], b["friction"], b["role"],
                          b["color"], b["impact_duration"]) for b in document["bodies"])
    phases = tuple(Phase3D(p["start_time"], tuple(static_from_dict(s, "world3d.phases.static_objects") for s in p["static_objects"]),
                           tuple((s["object_id"], State3D(s["position"], s["velocity"])) for s in p["states"]))
                   for p in document["phases"])
    pairs = tuple(((int(e["bodies"][0]), int(e["bodies"][1])), float(e["restitution"])) for e in document["pair_restitution"])
    anchor = document.get("anchor")
    if anchor is not None:
        anchor = Anchor3D(float(anchor["time"]), tuple((s["object_id"], State3D(s["position"], s["velocity"])) for s in anchor["states"]))
    fitted = tuple(FittedProperty(f["kind"], f["object_id"], f["value"], f["std"], f.get("measurements", 1), f.get("other_object_id"))
                   for f in document.get("fitted_properties", ()))
    return World3D(bodies, phases, document["gravity"], pairs, document["patient_zone"], dict(document["provenance"]),
                   fps=float(document.get("fps", DEFAULT_FPS)), anchor=anchor, horizon_frames=document.get("horizon_frames"),
                   fitted=fitted)


def is_world3d_document(document: object) -> bool:
    """True for a document that declares the 3D world format (validated separately)."""
    return isinstance(document, dict) and document.get("format") == WORLD3D_FORMAT
