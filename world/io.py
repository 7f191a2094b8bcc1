"""JSON documents for World and Rollout, validated against ``schemas/*.schema.json``.

Round trips are lossless: floats are written as Python floats (shortest repr,
exact under ``json``), arrays as nested lists, and every field of the
dataclasses is present (absent optionals are ``null``).
"""

from __future__ import annotations

import json
import math
from functools import lru_cache
from pathlib import Path
from typing import Any, Mapping

import jsonschema
import numpy as np
from jsonschema.exceptions import best_match

from schemas import read_schema
from world.types import ATTRIBUTE_VALUES, Anchor, AttributeBelief, Body, BodyState, Camera, Edit, Event, Rollout, Shape, World

WORLD_FORMAT = "physmind.world/1"
ROLLOUT_FORMAT = "physmind.rollout/1"


@lru_cache(maxsize=None)
def _validator(name: str):
    schema = read_schema(name)
    jsonschema.Draft202012Validator.check_schema(schema)
    return jsonschema.Draft202012Validator(schema)


def _validate(document: object, name: str, what: str) -> None:
    errors = list(_validator(name).iter_errors(document))
    if errors:
        # best_match descends into oneOf/anyOf to the most specific failing field.
        first = best_match(errors)
        where = "/".join(str(p) for p in first.absolute_path) or "(root)"
        more = f" (and {len(errors) - 1} more)" if len(errors) > 1 else ""
        raise ValueError(f"{what} document invalid at {where}: {first.message}{more}")


def validate_world_dict(document: object) -> None:
    """Raise ValueError (with the JSON path) unless ``document`` follows world.schema.json."""
    _validate(document, "world.schema.json", "world")


def validate_rollout_dict(document: object) -> None:
    """Raise ValueError (with the JSON path) unless ``document`` follows rollout.schema.json."""
    _validate(document, "rollout.schema.json", "rollout")


# --------------------------------------------------------------------------- world

def _state_to_dict(state: BodyState) -> dict[str, Any]:
    document = {"position": list(state.position), "velocity": list(state.velocity),
                "yaw": float(state.yaw), "yaw_rate": float(state.yaw_rate), "time": float(state.time)}
    # Written only when set, so documents from before the rolling model read back unchanged.
    if state.spin_velocity is not None:
        document["spin_velocity"] = list(state.spin_velocity)
    return document


def _state_from_dict(st: Mapping[str, Any]) -> BodyState:
    spin = st.get("spin_velocity")
    return BodyState(tuple(st["position"]), tuple(st["velocity"]), st["yaw"], st["yaw_rate"], st["time"],
                     None if spin is None else tuple(spin))


def _body_to_dict(body: Body) -> dict[str, Any]:
    shape = body.shape
    return {
        "id": int(body.id),
        "shape": {"kind": shape.kind, "radius": float(shape.radius), "half_extent": float(shape.half_extent),
                  "half_height": float(shape.half_height), "mesh_path": shape.mesh_path},
        "initial": _state_to_dict(body.initial),
        "mass": float(body.mass), "friction": float(body.friction), "restitution": float(body.restitution),
        "color": body.color, "material": body.material,
        "active_until": None if body.active_until is None else float(body.active_until),
        # Written only for rolling spheres (older documents read back unchanged).
        **({} if body.rolling_friction is None else {"rolling_friction": float(body.rolling_friction)}),
        # Written only when set (friction between bodies; older documents read back unchanged).
        **({} if body.contact_friction is None else {"contact_friction": float(body.contact_friction)}),
        # Written only for perceived bodies (older documents and oracle worlds read back unchanged).
        **({} if body.attribute_belief is None else {"attribute_belief": attribute_belief_to_dict(body.attribute_belief)}),
    }


def attribute_belief_to_dict(belief: AttributeBelief) -> dict[str, Any]:
    """{"color": {value: p}, "material": {...}, "shape": {...}, "support_frames": n}: the JSON form of a belief."""
    return {**{name: belief.distribution(name) for name in ATTRIBUTE_VALUES}, "support_frames": belief.support_frames}


def attribute_belief_from_dict(document: Mapping[str, Any] | None) -> AttributeBelief | None:
    """The inverse of :func:`attribute_belief_to_dict` (None stays None); ValueError names the field."""
    if document is None:
        return None
    missing = [name for name in ATTRIBUTE_VALUES if not isinstance(document.get(name) if isinstance(document, Mapping) else None, Mapping)]
    if missing:
        raise ValueError(f"attribute_belief: {', '.join(missing)} must be objects mapping each value to its probability")
    return AttributeBelief.from_mappings(document["color"], document["material"], document["shape"],
                                         document.get("support_frames", 0))


def camera_to_dict(camera: Camera) -> dict[str, Any]:
    """A Camera as the JSON object used in world documents and the generator's ground truth."""
    return {"width": int(camera.width), "height": int(camera.height), "fx": float(camera.fx), "fy": float(camera.fy),
            "cx": float(camera.cx), "cy": float(camera.cy), "position": list(camera.position),
            "rotation": [list(row) for row in camera.rotation]}


def camera_from_dict(document: Mapping[str, Any], where: str = "camera") -> Camera:
    """A Camera from a camera object, bare or under a ``"camera"`` key (a generator
    ground-truth file works as is); extra keys such as ``fovy_deg`` are ignored.

    Fields (OpenCV convention): width, height (pixels), fx, fy, cx, cy (pixels),
    position [x, y, z] (m), rotation 3x3 row-major camera-to-world.
    Raises ValueError naming the field.
    """
    if isinstance(document, Mapping) and isinstance(document.get("camera"), Mapping):
        document, where = document["camera"], f"{where}.camera"
    if not isinstance(document, Mapping):
        raise ValueError(f"{where}: expected a JSON object")
    convention = document.get("convention", "opencv")
    if convention != "opencv":
        raise ValueError(f"{where}.convention: only 'opencv' is supported, got {convention!r}")
    for name in ("width", "height"):
        value = document.get(name)
        if not isinstance(value, int) or isinstance(value, bool) or value <= 0:
            raise ValueError(f"{where}.{name}: expected a positive integer, got {value!r}")
    for name in ("fx", "fy", "cx", "cy"):
        value = document.get(name)
        if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
            raise ValueError(f"{where}.{name}: expected a finite number, got {value!r}")
    position = document.get("position")
    if not (isinstance(position, list) and len(position) == 3 and all(isinstance(v, (int, float)) for v in position)):
        raise ValueError(f"{where}.position: expected [x, y, z] in metres, got {position!r}")
    rotation = document.get("rotation")
    if not (isinstance(rotation, list) and len(rotation) == 3 and all(isinstance(r, list) and len(r) == 3 for r in rotation)):
        raise ValueError(f"{where}.rotation: expected a 3x3 row-major matrix, got {rotation!r}")
    try:
        return Camera(
            width=int(document["width"]), height=int(document["height"]),
            fx=float(document["fx"]), fy=float(document["fy"]), cx=float(document["cx"]), cy=float(document["cy"]),
            position=tuple(float(v) for v in position), rotation=tuple(tuple(float(v) for v in row) for row in rotation),
        )
    except (TypeError, ValueError) as error:
        raise ValueError(f"{where}: {error}") from None


def read_json_file(path: str | Path, what: str = "file") -> Any:
    """Parse a JSON file; FileNotFoundError / ValueError say which ``what`` and why, never a traceback."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no such {what}: {path}")
    try:
        return json.loads(path.read_text())
    except json.JSONDecodeError as error:
        raise ValueError(f"{what} {path}: not valid JSON ({error.msg} at line {error.lineno})") from None
    except UnicodeDecodeError:
        raise ValueError(f"{what} {path}: not a text file") from None


def load_camera(path: str | Path) -> Camera:
    """Read a camera JSON file (a bare camera, or any document with a ``camera`` key)."""
    return camera_from_dict(read_json_file(path, "camera file"), where=f"camera file {Path(path).name}")


def _strict_json(value: Any, field: str) -> Any:
    """A deep copy through JSON; NaN or infinity (not JSON) is a ValueError naming the field."""
    try:
        return json.loads(json.dumps(value, allow_nan=False))
    except ValueError:
        raise ValueError(f"{field}: holds NaN or infinity, which JSON cannot carry") from None


def world_to_dict(world: World) -> dict[str, Any]:
    """The World as a JSON-ready dict following world.schema.json."""
    return {
        "format": WORLD_FORMAT,
        "id": world.id,
        "fps": float(world.fps),
        "observed_frames": int(world.observed_frames),
        "gravity": float(world.gravity),
        "bodies": [_body_to_dict(b) for b in world.bodies],
        "pair_restitution": [{"bodies": [int(a), int(b)], "restitution": float(e)} for a, b, e in world.pair_restitution],
        "camera": None if world.camera is None else camera_to_dict(world.camera),
        "provenance": _strict_json(dict(world.provenance), "provenance"),
        "anchor": None if world.anchor is None else {
            "time": float(world.anchor.time),
            "states": [{"body": int(i), "state": _state_to_dict(st)} for i, st in world.anchor.states],
        },
        # Written only when known, so older documents read back unchanged.
        **({"observed_collisions": [{"bodies": [a, b], "frame": f} for a, b, f in world.observed_collisions]}
           if world.observed_collisions is not None else {}),
        **({"contact_slip_removal": float(world.contact_slip_removal)} if world.contact_slip_removal != 1.0 else {}),
    }


def world_from_dict(document: Mapping[str, Any]) -> World:
    """Parse and validate a world document; ValueError names the offending field."""
    validate_world_dict(document)
    bodies = []
    for index, b in enumerate(document["bodies"]):
        try:
            s, st = b["shape"], b["initial"]
            bodies.append(Body(
                id=b["id"],
                shape=Shape(s["kind"], radius=s["radius"], half_extent=s["half_extent"],
                            half_height=s["half_height"], mesh_path=s["mesh_path"]),
                initial=_state_from_dict(st),
                mass=b["mass"], friction=b["friction"], restitution=b["restitution"],
                color=b["color"], material=b["material"], active_until=b["active_until"],
                rolling_friction=b.get("rolling_friction"), contact_friction=b.get("contact_friction"),
                attribute_belief=attribute_belief_from_dict(b.get("attribute_belief"))))
        except ValueError as error:
            raise ValueError(f"bodies[{index}]: {error}") from None
    camera = None if document["camera"] is None else camera_from_dict(document["camera"])
    return World(
        bodies=tuple(bodies),
        fps=document["fps"],
        observed_frames=document["observed_frames"],
        gravity=document["gravity"],
        pair_restitution=tuple((p["bodies"][0], p["bodies"][1], p["restitution"]) for p in document["pair_restitution"]),
        camera=camera,
        id=document["id"],
        provenance=json.loads(json.dumps(document["provenance"])),
        anchor=_anchor_from_dict(document.get("anchor")),
        observed_collisions=None if "observed_collisions" not in document else
        tuple((c["bodies"][0], c["bodies"][1], c["frame"]) for c in document["observed_collisions"]),
        contact_slip_removal=document.get("contact_slip_removal", 1.0),
    )


def _anchor_from_dict(anchor: Mapping[str, Any] | None) -> Anchor | None:
    if anchor is None:
        return None
    states = []
    for index, entry in enumerate(anchor["states"]):
        try:
            states.append((entry["body"], _state_from_dict(entry["state"])))
        except ValueError as error:
            raise ValueError(f"anchor.states[{index}]: {error}") from None
    return Anchor(anchor["time"], tuple(states))


# --------------------------------------------------------------------------- rollout

def edit_to_dict(edit: Edit) -> dict[str, Any]:
    value = edit.value
    if isinstance(value, (tuple, list, np.ndarray)):
        value = [float(v) for v in value]
    elif value is not None:
        value = float(value)
    return {"kind": edit.kind, "body": int(edit.body), "value": value,
            "other": None if edit.other is None else int(edit.other),
            "from_frame": None if edit.from_frame is None else int(edit.from_frame)}


# The tool API names the same fields for agents (schemas/tools/simulate_edit.*).
_TOOL_EDIT_KEYS = {"kind": "edit_type", "body": "object_id", "from_frame": "start_frame", "value": "value", "other": "other_object_id"}


def edit_to_tool_record(edit: Edit) -> dict[str, Any]:
    """The edit in the tool API's vocabulary (edit_type, object_id, start_frame, value, other_object_id)."""
    return {_TOOL_EDIT_KEYS[key]: value for key, value in edit_to_dict(edit).items()}


def edit_from_dict(document: Mapping[str, Any]) -> Edit:
    value = document.get("value")
    if isinstance(value, list):
        value = tuple(value)
    return Edit(kind=document["kind"], body=document["body"], value=value,
                other=document.get("other"), from_frame=document.get("from_frame"))


def event_to_dict(event: Event) -> dict[str, Any]:
    return {"kind": event.kind, "bodies": [int(b) for b in event.bodies], "time": float(event.time),
            "frame": int(event.frame), "position": [float(v) for v in event.position], "impulse": float(event.impulse)}


def event_from_dict(document: Mapping[str, Any]) -> Event:
    return Event(kind=document["kind"], bodies=tuple(document["bodies"]), time=document["time"],
                 frame=document["frame"], position=tuple(document["position"]), impulse=document["impulse"])


def rollout_to_dict(rollout: Rollout) -> dict[str, Any]:
    """The Rollout as a JSON-ready dict following rollout.schema.json."""
    return {
        "format": ROLLOUT_FORMAT,
        "id": rollout.id,
        "world_id": rollout.world_id,
        "edits": [edit_to_dict(e) for e in rollout.edits],
        "fps": float(rollout.fps),
        "observed_frames": int(rollout.observed_frames),
        "horizon_frames": int(rollout.horizon_frames),
        "body_ids": [int(b) for b in rollout.body_ids],
        "times": np.asarray(rollout.times, dtype=float).tolist(),
        "positions": np.asarray(rollout.positions, dtype=float).tolist(),
        "velocities": np.asarray(rollout.velocities, dtype=float).tolist(),
        "yaw": np.asarray(rollout.yaw, dtype=float).tolist(),
        "active": np.asarray(rollout.active, dtype=bool).tolist(),
        "visible": np.asarray(rollout.visible, dtype=bool).tolist(),
        "events": [event_to_dict(e) for e in rollout.events],
        "notes": list(rollout.notes),
    }


def rollout_from_dict(document: Mapping[str, Any]) -> Rollout:
    """Parse and validate a rollout document; ValueError names the offending field."""
    validate_rollout_dict(document)
    n_frames, n_bodies = document["horizon_frames"], len(document["body_ids"])

    def array(name: str, dtype, tail: tuple[int, ...]) -> np.ndarray:
        values = np.asarray(document[name], dtype=dtype)
        expected = (n_frames, n_bodies) + tail if name != "times" else (n_frames,)
        if values.size == 0:
            values = values.reshape(expected)
        if values.shape != expected:
            raise ValueError(f"rollout document invalid at {name}: expected shape {expected}, got {values.shape}")
        return values

    return Rollout(
        id=document["id"],
        world_id=document["world_id"],
        edits=tuple(edit_from_dict(e) for e in document["edits"]),
        fps=document["fps"],
        observed_frames=document["observed_frames"],
        body_ids=tuple(document["body_ids"]),
        times=array("times", float, ()),
        positions=array("positions", float, (3,)),
        velocities=array("velocities", float, (3,)),
        yaw=array("yaw", float, ()),
        active=array("active", bool, ()),
        visible=array("visible", bool, ()),
        events=tuple(event_from_dict(e) for e in document["events"]),
        notes=tuple(document["notes"]),
    )
