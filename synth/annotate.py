"""JSON documents of one scene: CLEVRER annotation, hidden ground truth, mask proposals.

All floats are rounded (positions 1e-4 m, quaternions 1e-5) so the files are
compact and byte-for-byte reproducible. See docs/formats.md for every field.
"""

from __future__ import annotations

import mujoco
import numpy as np

from planner.program import EventRecord, ObjectRecord, ProgramScene
from synth.masks import bbox_of, encode_mask
from synth.mjcf import CONTACT_HALF_PERIOD, NATIVE_CCD, TIMESTEP, pair_restitution
from synth.looks import look_document
from synth.scene import GRAVITY, SceneSpec, camera_fovy_deg, camera_geometry
from synth.simulate import DEBOUNCE_SECONDS, SimResult
from world.types import Event

MIN_SEEN_FRAMES = 5  # an object shown in fewer observed frames is not named in questions

GENERATOR_VERSION = "synth-3"  # synth-3: libccd collisions (synth.mjcf.NATIVE_CCD); synth-2 added ground_truth.look


def video_filename(index: int) -> str:
    return f"video_{index:05d}.mp4"


def _r(values, digits: int = 4) -> list[float]:
    return [round(float(v), digits) + 0.0 for v in values]  # + 0.0 turns -0.0 into 0.0


def annotation_document(spec: SceneSpec, sim: SimResult) -> dict:
    """CLEVRER's annotation_XXXXX.json for the observed frames."""
    objects = sorted(spec.objects, key=lambda o: o.object_id)
    trajectory = []
    for frame in range(spec.observed_frames):
        rows = []
        for k, oid in enumerate(sim.object_ids):
            rows.append(
                {
                    "object_id": int(oid),
                    "location": _r(sim.positions[frame, k]),
                    "orientation": _r(sim.quaternions[frame, k], 5),
                    "velocity": _r(sim.velocities[frame, k]),
                    "angular_velocity": _r(sim.angular_velocities[frame, k]),
                    "inside_camera_view": bool(sim.visible[frame, k]),
                }
            )
        trajectory.append({"frame_id": frame, "objects": rows})
    collisions = [
        {"object_ids": [int(i) for i in e.bodies], "frame_id": int(e.frame), "location": _r(e.position)}
        for e in sim.collisions
        if e.frame < spec.observed_frames
    ]
    return {
        "scene_index": spec.scene_index,
        "video_filename": video_filename(spec.scene_index),
        "object_property": [{"object_id": o.object_id, "color": o.color, "material": o.material, "shape": o.shape} for o in objects],
        "motion_trajectory": trajectory,
        "collision": collisions,
    }


def event_document(event: Event, observed_frames: int) -> dict:
    return {
        "kind": event.kind,
        "object_ids": [int(i) for i in event.bodies],
        "frame_id": int(event.frame),
        "time": round(float(event.time), 4),
        "location": _r(event.position),
        "observed": bool(event.frame < observed_frames),
    }


def camera_document(spec: SceneSpec) -> dict:
    cam = spec.camera
    return {
        "convention": "opencv",
        "width": cam.width,
        "height": cam.height,
        "fx": round(cam.fx, 6),
        "fy": round(cam.fy, 6),
        "cx": cam.cx,
        "cy": cam.cy,
        "position": _r(cam.position, 6),
        "rotation": [_r(row, 8) for row in cam.rotation],
        "fovy_deg": round(camera_fovy_deg(cam), 6),
    }


def _size_document(shape: str, half: float) -> dict:
    if shape == "sphere":
        return {"radius": half}
    if shape == "cube":
        return {"half_extent": half}
    return {"radius": half, "half_height": half}


def ground_truth_document(spec: SceneSpec, sim: SimResult, counterfactuals: dict[int, SimResult], seed: int, attempts: int) -> dict:
    """ground_truth/scene_XXXXX.json: what CLEVRER keeps hidden."""
    objects = []
    for o in sorted(spec.objects, key=lambda o: o.object_id):
        objects.append(
            {
                "object_id": o.object_id,
                "color": o.color,
                "material": o.material,
                "shape": o.shape,
                "size": _size_document(o.shape, o.half_size),
                "mass": round(o.mass, 4),
                "friction": round(o.friction, 5),
                "rolling_friction": round(o.rolling_friction, 5),
                "torsional_friction": round(o.torsional_friction, 5),
                "restitution": round(o.restitution, 5),
                "role": o.role,
                "launch_frame": o.launch_frame,
                "initial": {"position": _r(o.position), "velocity": _r(o.velocity), "yaw": round(o.yaw, 6)},
            }
        )
    by_pair = []
    ordered = sorted(spec.objects, key=lambda o: o.object_id)
    for i, a in enumerate(ordered):
        for b in ordered[i + 1 :]:
            by_pair.append({"object_ids": [a.object_id, b.object_id], "restitution": round(pair_restitution(a, b), 5), "friction": round(0.5 * (a.friction + b.friction), 5)})
    trajectory_objects = []
    for k, oid in enumerate(sim.object_ids):
        trajectory_objects.append(
            {
                "object_id": int(oid),
                "location": [_r(p) for p in sim.positions[:, k]],
                "orientation": [_r(q, 5) for q in sim.quaternions[:, k]],
                "velocity": [_r(v) for v in sim.velocities[:, k]],
                "angular_velocity": [_r(w) for w in sim.angular_velocities[:, k]],
                "inside_camera_view": [bool(v) for v in sim.visible[:, k]],
            }
        )
    return {
        "scene_index": spec.scene_index,
        "video_filename": video_filename(spec.scene_index),
        "generator": {"version": GENERATOR_VERSION, "seed": seed, "sampling_attempts": attempts},
        "fps": spec.fps,
        "observed_frames": spec.observed_frames,
        "horizon_frames": spec.horizon_frames,
        "physics": {
            "engine": "mujoco",
            "mujoco_version": mujoco.__version__,
            "timestep": TIMESTEP,
            "gravity": GRAVITY,
            "contact_half_period": CONTACT_HALF_PERIOD,
            "native_ccd": NATIVE_CCD,
            "collision_debounce_seconds": DEBOUNCE_SECONDS,
            "pair_parameters": by_pair,
        },
        "camera": camera_document(spec),
        "look": {**look_document(spec.look), "camera_geometry": {k: round(v, 4) for k, v in camera_geometry(spec.camera).items()}},
        "objects": objects,
        "trajectory": {"frame_ids": list(range(spec.horizon_frames)), "objects": trajectory_objects},
        "events": [event_document(e, spec.observed_frames) for e in sim.events],
        "counterfactual": [
            {
                "removed_object_id": int(oid),
                "events": [event_document(e, spec.observed_frames) for e in cf.events],
                "locations_at_video_end": [
                    {"object_id": int(i), "location": _r(cf.positions[spec.observed_frames - 1, k])} for k, i in enumerate(cf.object_ids)
                ],
            }
            for oid, cf in sorted(counterfactuals.items())
        ],
    }


def proposals_document(spec: SceneSpec, instance: np.ndarray) -> dict:
    """masks/proposal_XXXXX.json: per-frame instance masks (COCO RLE) from the segmentation render.

    instance: (F, H, W) object id per pixel (-1 = floor).
    """
    attributes = {o.object_id: o for o in spec.objects}
    frames = []
    for frame in range(instance.shape[0]):
        rows = []
        for oid in sorted(attributes):
            mask = instance[frame] == oid
            area = int(mask.sum())
            if area == 0:
                continue
            o = attributes[oid]
            rows.append(
                {
                    "object_id": oid,
                    "color": o.color,
                    "material": o.material,
                    "shape": o.shape,
                    "score": 1.0,
                    "area": area,
                    "bbox": bbox_of(mask),
                    "mask": encode_mask(mask),
                }
            )
        frames.append({"frame_index": frame, "objects": rows})
    return {
        "scene_index": spec.scene_index,
        "video_filename": video_filename(spec.scene_index),
        "height": spec.camera.height,
        "width": spec.camera.width,
        "frames": frames,
    }


# --- ground truth -> program scene (shared by the generator and the tests) ---


def seen_object_ids(ground_truth: dict, min_frames: int = MIN_SEEN_FRAMES) -> frozenset[int]:
    """Ids of the objects whose centre is in view in at least ``min_frames`` observed frames."""
    observed = int(ground_truth["observed_frames"])
    return frozenset(
        int(o["object_id"]) for o in ground_truth["trajectory"]["objects"] if sum(bool(v) for v in o["inside_camera_view"][:observed]) >= min_frames
    )


def _event_record(row: dict) -> EventRecord:
    return EventRecord(kind=row["kind"], objects=tuple(row["object_ids"]), frame=int(row["frame_id"]))


def program_scene_from_ground_truth(ground_truth: dict) -> ProgramScene:
    """A planner.program scene whose events are MuJoCo's (factual and counterfactual)."""
    objects = tuple(ObjectRecord(o["object_id"], o["color"], o["material"], o["shape"]) for o in ground_truth["objects"])
    events = tuple(_event_record(e) for e in ground_truth["events"] if e["kind"] in ("collision", "in", "out"))
    counterfactual = {cf["removed_object_id"]: tuple(_event_record(e) for e in cf["events"]) for cf in ground_truth["counterfactual"]}

    def replay(removed: int) -> tuple[EventRecord, ...]:
        return counterfactual[removed]

    return ProgramScene(objects=objects, events=events, observed_frames=int(ground_truth["observed_frames"]), counterfactual=replay)

