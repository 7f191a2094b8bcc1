"""The one observation type that identification consumes.

Perception (video), oracle annotations (CLEVRER's format) and tests all meet
here: per object an anonymous id, optional attributes and shape, and per
frame a position on the support plane, a yaw, a visibility flag and a
confidence weight.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from world.io import attribute_belief_from_dict, attribute_belief_to_dict, camera_from_dict, camera_to_dict, read_json_file
from world.types import COLORS, MATERIALS, SHAPE_KINDS, AttributeBelief, Camera, Shape

# CLEVRER uses one object size; the generator (synth/) writes SI metres with
# this size, and real CLEVRER annotations need the caller's own dimensions.
DEFAULT_OBJECT_SIZE = 0.2  # metres: sphere/cylinder radius, cube half-extent


def default_shape(kind: str, size: float = DEFAULT_OBJECT_SIZE) -> Shape:
    """The single CLEVRER-style object size for ``kind`` (metres)."""
    if kind == "sphere":
        return Shape("sphere", radius=size)
    if kind == "cube":
        return Shape("cube", half_extent=size)
    if kind == "cylinder":
        return Shape("cylinder", radius=size, half_height=size)
    raise ValueError(f"shape: expected one of {SHAPE_KINDS}, got {kind!r}")


@dataclass(frozen=True)
class ObjectTrack:
    """Everything observed about one object.

    frames: (T,) int64 frame indices, strictly increasing, within the video.
    positions: (T, 3) float64 world-frame centre positions, metres.
    yaw: (T,) float64 radians about +z; NaN where unknown.
    visible: (T,) bool, the object is inside the camera view.
    weights: (T,) float64 in [0, 1], confidence of each position
    (0 for frames that must not count, e.g. out of view).
    color, material: the decided attributes (None: unknown).
    attribute_belief: perception's probability of each attribute value
    (None: the attributes are taken as given, e.g. oracle annotations).
    """

    id: int
    shape: Shape
    frames: np.ndarray
    positions: np.ndarray
    yaw: np.ndarray
    visible: np.ndarray
    weights: np.ndarray
    color: str | None = None
    material: str | None = None
    attribute_belief: AttributeBelief | None = None

    def __post_init__(self) -> None:
        where = f"object {self.id}"
        if self.attribute_belief is not None and not isinstance(self.attribute_belief, AttributeBelief):
            raise ValueError(f"{where}: attribute_belief: expected an AttributeBelief or None, got {type(self.attribute_belief).__name__}")
        if not isinstance(self.id, (int, np.integer)) or isinstance(self.id, bool) or self.id < 0:
            raise ValueError(f"object id: expected an integer >= 0, got {self.id!r}")
        if self.color is not None and self.color not in COLORS:
            raise ValueError(f"{where}: color: expected one of {COLORS}, got {self.color!r}")
        if self.material is not None and self.material not in MATERIALS:
            raise ValueError(f"{where}: material: expected one of {MATERIALS}, got {self.material!r}")
        frames = np.asarray(self.frames, dtype=np.int64).reshape(-1)
        count = frames.shape[0]
        arrays = {
            "positions": (np.asarray(self.positions, dtype=np.float64), (count, 3)),
            "yaw": (np.asarray(self.yaw, dtype=np.float64).reshape(-1), (count,)),
            "visible": (np.asarray(self.visible, dtype=bool).reshape(-1), (count,)),
            "weights": (np.asarray(self.weights, dtype=np.float64).reshape(-1), (count,)),
        }
        for name, (array, shape) in arrays.items():
            if array.shape != shape:
                raise ValueError(f"{where}: {name}: expected shape {shape}, got {array.shape}")
        if count and np.any(np.diff(frames) <= 0):
            raise ValueError(f"{where}: frames: must be strictly increasing (duplicate or unsorted frame ids)")
        if count and frames[0] < 0:
            raise ValueError(f"{where}: frames: negative frame id {int(frames[0])}")
        if not np.all(np.isfinite(arrays["positions"][0])):
            bad = int(frames[np.argmax(~np.all(np.isfinite(arrays["positions"][0]), axis=1))])
            raise ValueError(f"{where}: positions: NaN or infinite value at frame {bad}")
        weights = arrays["weights"][0]
        if np.any(~np.isfinite(weights)) or np.any(weights < 0) or np.any(weights > 1):
            raise ValueError(f"{where}: weights: must be finite and in [0, 1]")
        object.__setattr__(self, "frames", frames)
        for name, (array, _) in arrays.items():
            array.setflags(write=False)
            object.__setattr__(self, name, array)
        frames.setflags(write=False)

    @property
    def observed(self) -> np.ndarray:
        """(T,) bool mask of frames that count for fitting (weight > 0)."""
        return self.weights > 0


@dataclass(frozen=True)
class Observations:
    """A video's objects as observed: tracks plus the video's frame clock.

    fps: frames per second; num_frames: frames in the video (observed
    window); camera: optional, the true or estimated camera.
    """

    objects: tuple[ObjectTrack, ...]
    fps: float = 25.0
    num_frames: int = 128
    camera: Camera | None = None
    source: Mapping[str, object] = field(default_factory=dict)

    def __post_init__(self) -> None:
        ids = [o.id for o in self.objects]
        duplicates = sorted({i for i in ids if ids.count(i) > 1})
        if duplicates:
            raise ValueError(f"objects: duplicate object ids {duplicates}")
        if not (isinstance(self.fps, (int, float)) and math.isfinite(self.fps) and self.fps > 0):
            raise ValueError(f"fps: must be a finite number > 0, got {self.fps!r}")
        if not isinstance(self.num_frames, (int, np.integer)) or self.num_frames < 0:
            raise ValueError(f"num_frames: must be an integer >= 0, got {self.num_frames!r}")
        for track in self.objects:
            if track.frames.size and track.frames[-1] >= self.num_frames:
                raise ValueError(
                    f"object {track.id}: frame {int(track.frames[-1])} is beyond the video's {self.num_frames} frames"
                )

    def object(self, object_id: int) -> ObjectTrack:
        for track in self.objects:
            if track.id == object_id:
                return track
        raise KeyError(f"unknown object id {object_id!r}; known ids {[o.id for o in self.objects]}")

    # ----------------------------------------------------------- adapters
    @classmethod
    def from_clevrer_annotation(
        cls,
        source: str | Path | Mapping[str, object],
        *,
        object_size: float = DEFAULT_OBJECT_SIZE,
        fps: float = 25.0,
        num_frames: int | None = None,
        camera: Camera | None = None,
        use_out_of_view: bool = False,
    ) -> "Observations":
        """Read CLEVRER's ``annotation_XXXXX.json`` (as synth/ writes it).

        Frames where ``inside_camera_view`` is false keep their positions but
        get weight 0 unless ``use_out_of_view`` (a camera only sees what is in
        view; oracle tracks stay comparable with perceived ones).
        num_frames defaults to one past the last annotated frame.
        """
        annotation = _load_json(source)
        where = str(source) if not isinstance(source, Mapping) else "annotation"
        properties = _require_list(annotation, "object_property", where)
        trajectory = _require_list(annotation, "motion_trajectory", where)
        per_object: dict[int, dict[str, list]] = {}
        attributes: dict[int, dict[str, str]] = {}
        for entry in properties:
            object_id = _require_int(entry, "object_id", f"{where}: object_property")
            if object_id in attributes:
                raise ValueError(f"{where}: object_property: duplicate object_id {object_id}")
            shape = entry.get("shape")
            if shape not in SHAPE_KINDS:
                raise ValueError(f"{where}: object_property[{object_id}].shape: expected one of {SHAPE_KINDS}, got {shape!r}")
            attributes[object_id] = {"color": entry.get("color"), "material": entry.get("material"), "shape": shape}
            per_object[object_id] = {"frames": [], "positions": [], "yaw": [], "visible": []}
        last_frame = -1
        for frame_entry in trajectory:
            frame = _require_int(frame_entry, "frame_id", f"{where}: motion_trajectory")
            last_frame = max(last_frame, frame)
            for obj in _require_list(frame_entry, "objects", f"{where}: frame {frame}"):
                object_id = _require_int(obj, "object_id", f"{where}: frame {frame}")
                if object_id not in per_object:
                    raise ValueError(f"{where}: frame {frame}: object_id {object_id} is not in object_property")
                location = obj.get("location")
                if not (isinstance(location, list) and len(location) == 3):
                    raise ValueError(f"{where}: frame {frame}: object {object_id}: location must be 3 numbers")
                record = per_object[object_id]
                record["frames"].append(frame)
                record["positions"].append([float("nan") if v is None else float(v) for v in location])
                record["yaw"].append(_yaw_from_quaternion(obj.get("orientation")))
                record["visible"].append(bool(obj.get("inside_camera_view", True)))
        tracks = []
        for object_id, record in sorted(per_object.items()):
            order = np.argsort(record["frames"], kind="stable")
            frames = np.asarray(record["frames"], dtype=np.int64)[order]
            if frames.size and np.any(np.diff(frames) == 0):
                raise ValueError(f"{where}: object {object_id}: appears twice in one frame")
            visible = np.asarray(record["visible"], dtype=bool)[order]
            weights = np.ones(frames.shape) if use_out_of_view else visible.astype(np.float64)
            attrs = attributes[object_id]
            tracks.append(
                ObjectTrack(
                    id=object_id,
                    shape=default_shape(attrs["shape"], object_size),
                    frames=frames,
                    positions=np.asarray(record["positions"], dtype=np.float64).reshape(-1, 3)[order],
                    yaw=np.asarray(record["yaw"], dtype=np.float64)[order],
                    visible=visible,
                    weights=weights,
                    color=attrs["color"],
                    material=attrs["material"],
                )
            )
        return cls(
            objects=tuple(tracks),
            fps=fps,
            num_frames=num_frames if num_frames is not None else last_frame + 1,
            camera=camera,
            source={"kind": "clevrer_annotation", "path": where},
        )

    @classmethod
    def from_dict(cls, document: Mapping[str, object]) -> "Observations":
        """Inverse of :meth:`to_dict` (the ``observations.json`` format)."""
        objects = []
        for entry in _require_list(document, "objects", "observations"):
            shape_doc = entry.get("shape")
            if not isinstance(shape_doc, Mapping):
                raise ValueError(f"observations: object {entry.get('id')!r}: shape must be an object")
            records = _require_list(entry, "frames", f"observations: object {entry.get('id')!r}")
            objects.append(
                ObjectTrack(
                    id=_require_int(entry, "id", "observations: objects"),
                    shape=Shape(**shape_doc),
                    frames=np.array([r["frame"] for r in records], dtype=np.int64),
                    positions=np.array([r["position"] for r in records], dtype=np.float64).reshape(-1, 3),
                    yaw=np.array([np.nan if r.get("yaw") is None else r["yaw"] for r in records], dtype=np.float64),
                    visible=np.array([r.get("visible", True) for r in records], dtype=bool),
                    weights=np.array([r.get("weight", 1.0) for r in records], dtype=np.float64),
                    color=entry.get("color"),
                    material=entry.get("material"),
                    attribute_belief=attribute_belief_from_dict(entry.get("attribute_belief")),
                )
            )
        camera = document.get("camera")
        return cls(
            objects=tuple(objects),
            fps=float(document.get("fps", 25.0)),
            num_frames=int(document.get("num_frames", 128)),
            camera=camera_from_dict(camera) if camera else None,
            source=dict(document.get("source", {})),
        )

    def to_dict(self) -> dict[str, object]:
        objects = []
        for track in self.objects:
            shape = {"kind": track.shape.kind, "radius": track.shape.radius, "half_extent": track.shape.half_extent, "half_height": track.shape.half_height}
            frames = [
                {
                    "frame": int(f),
                    "position": [float(v) for v in p],
                    "yaw": None if math.isnan(y) else float(y),
                    "visible": bool(vis),
                    "weight": float(w),
                }
                for f, p, y, vis, w in zip(track.frames, track.positions, track.yaw, track.visible, track.weights)
            ]
            entry = {"id": int(track.id), "color": track.color, "material": track.material, "shape": shape, "frames": frames}
            if track.attribute_belief is not None:
                entry["attribute_belief"] = attribute_belief_to_dict(track.attribute_belief)
            objects.append(entry)
        return {
            "fps": self.fps,
            "num_frames": int(self.num_frames),
            "camera": camera_to_dict(self.camera) if self.camera else None,
            "source": dict(self.source),
            "objects": objects,
        }


def _yaw_from_quaternion(quaternion: Sequence[float] | None) -> float:
    """Yaw (rad) about +z of an (x, y, z, w) quaternion; NaN when absent."""
    if not quaternion or len(quaternion) != 4 or any(v is None for v in quaternion):
        return float("nan")
    x, y, z, w = (float(v) for v in quaternion)
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def _load_json(source: str | Path | Mapping[str, object]) -> Mapping[str, object]:
    if isinstance(source, Mapping):
        return source
    path = Path(source)
    document = read_json_file(path, "annotation file")
    if not isinstance(document, Mapping):
        raise ValueError(f"{path}: expected a JSON object at the top level")
    return document


def _require_list(document: Mapping[str, object], key: str, where: str) -> list:
    value = document.get(key)
    if not isinstance(value, list):
        raise ValueError(f"{where}: missing or invalid '{key}' (expected a list)")
    return value


def _require_int(document: Mapping[str, object], key: str, where: str) -> int:
    value = document.get(key)
    if not isinstance(value, int) or isinstance(value, bool):
        raise ValueError(f"{where}: '{key}' must be an integer, got {value!r}")
    return value
