"""Frozen, self-validating types of a 3D world with static geometry.

Units: metres, seconds, kilograms; world frame z up, gravity (0, 0, -g).
Quaternions are (x, y, z, w), rotating box/body frame to world.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from world.timebase import frame_of
from world.types import STANDARD_GRAVITY

STATIC_ROLES: tuple[str, ...] = ("floor", "platform", "ramp", "wall", "pillar", "zone")
BODY_SHAPES: tuple[str, ...] = ("sphere", "cube")
BODY_ROLES: tuple[str | None, ...] = ("agent", "patient", None)


def _vector(values, length: int, name: str) -> tuple[float, ...]:
    array = np.asarray(values, dtype=float).reshape(-1)
    if array.shape != (length,) or not np.all(np.isfinite(array)):
        raise ValueError(f"{name}: expected {length} finite numbers, got {values!r}")
    return tuple(float(v) for v in array)


def quaternion_matrix(quaternion: tuple[float, float, float, float]) -> np.ndarray:
    """(3, 3) rotation matrix of a unit quaternion (x, y, z, w)."""
    x, y, z, w = quaternion
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


@dataclass(frozen=True)
class Face:
    """One rectangular face of a static box.

    normal: (3,) outward unit normal; center: (3,) face centre, m;
    axis_u, axis_v: (3,) unit in-plane axes; half_u, half_v: half lengths, m.
    """

    box_id: int
    normal: tuple[float, float, float]
    center: tuple[float, float, float]
    axis_u: tuple[float, float, float]
    axis_v: tuple[float, float, float]
    half_u: float
    half_v: float


@dataclass(frozen=True)
class StaticBox:
    """A static box: floor, platform, ramp (a tilted box), wall, pillar or zone (a flat patch).

    center: (3,) m; half_extents: (3,) m, all > 0; orientation: unit quaternion (x, y, z, w).
    A zone is not a physical surface: it only marks the region a body may touch.
    """

    id: int
    role: str
    center: tuple[float, float, float]
    half_extents: tuple[float, float, float]
    orientation: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)
    kind: str = "box"

    def __post_init__(self) -> None:
        if not isinstance(self.id, int) or isinstance(self.id, bool) or self.id < 0:
            raise ValueError(f"static object id: expected an integer >= 0, got {self.id!r}")
        if self.kind != "box":
            raise ValueError(f"static object {self.id}.kind: only 'box' is supported, got {self.kind!r}")
        if self.role not in STATIC_ROLES:
            raise ValueError(f"static object {self.id}.role: expected one of {STATIC_ROLES}, got {self.role!r}")
        object.__setattr__(self, "center", _vector(self.center, 3, f"static object {self.id}.center"))
        half = _vector(self.half_extents, 3, f"static object {self.id}.half_extents")
        if min(half) <= 0:
            raise ValueError(f"static object {self.id}.half_extents: expected values > 0, got {half}")
        object.__setattr__(self, "half_extents", half)
        quat = _vector(self.orientation, 4, f"static object {self.id}.orientation")
        norm = math.sqrt(sum(v * v for v in quat))
        if abs(norm - 1.0) > 1e-3:
            raise ValueError(f"static object {self.id}.orientation: expected a unit quaternion, norm {norm:.4f}")
        object.__setattr__(self, "orientation", tuple(v / norm for v in quat))

    @property
    def rotation(self) -> np.ndarray:
        """(3, 3) box-to-world rotation (columns are the box axes in world coordinates)."""
        return quaternion_matrix(self.orientation)

    def faces(self) -> tuple[Face, ...]:
        """The six faces, outward normals."""
        rot, half, center = self.rotation, np.asarray(self.half_extents), np.asarray(self.center)
        faces = []
        for axis in range(3):
            others = [k for k in range(3) if k != axis]
            for sign in (1.0, -1.0):
                normal = sign * rot[:, axis]
                faces.append(Face(
                    box_id=self.id, normal=tuple(normal), center=tuple(center + half[axis] * normal),
                    axis_u=tuple(rot[:, others[0]]), axis_v=tuple(rot[:, others[1]]),
                    half_u=float(half[others[0]]), half_v=float(half[others[1]]),
                ))
        return tuple(faces)


@dataclass(frozen=True)
class Body3D:
    """A dynamic body: a sphere (half_size = radius) or a cube (half_size = half side) kept axis-aligned.

    mass kg > 0; restitution in [0, 1] against static surfaces; friction >= 0
    (Coulomb, against static surfaces); impact_duration >= 0 s: how long a
    bounce on a static surface holds the body at the surface (0: instantaneous;
    soft contacts take a few hundredths of a second); role "agent", "patient" or None.
    """

    id: int
    shape: str
    half_size: float
    mass: float = 1.0
    restitution: float = 0.0
    friction: float = 0.0
    role: str | None = None
    color: str = "gray"
    impact_duration: float = 0.0

    def __post_init__(self) -> None:
        if not isinstance(self.id, int) or isinstance(self.id, bool) or self.id < 0:
            raise ValueError(f"body id: expected an integer >= 0, got {self.id!r}")
        if self.shape not in BODY_SHAPES:
            raise ValueError(f"body {self.id}.shape: expected one of {BODY_SHAPES}, got {self.shape!r}")
        for name, value, low, high in (("half_size", self.half_size, 1e-6, math.inf), ("mass", self.mass, 1e-9, math.inf),
                                       ("restitution", self.restitution, 0.0, 1.0), ("friction", self.friction, 0.0, math.inf),
                                       ("impact_duration", self.impact_duration, 0.0, 1.0)):
            if not (isinstance(value, (int, float)) and math.isfinite(value) and low <= value <= high):
                raise ValueError(f"body {self.id}.{name}: expected a finite number in [{low}, {high}], got {value!r}")
        if self.role not in BODY_ROLES:
            raise ValueError(f"body {self.id}.role: expected one of {BODY_ROLES}, got {self.role!r}")


@dataclass(frozen=True)
class State3D:
    """position (3,) m and velocity (3,) m/s of a body's centre."""

    position: tuple[float, float, float]
    velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        object.__setattr__(self, "position", _vector(self.position, 3, "state.position"))
        object.__setattr__(self, "velocity", _vector(self.velocity, 3, "state.velocity"))


@dataclass(frozen=True)
class Phase3D:
    """One configuration between curtains: its start time (s), static geometry and initial states.

    states: (body_id, State3D) pairs at ``start_time``; bodies not listed are absent in this phase.
    """

    start_time: float
    static_objects: tuple[StaticBox, ...]
    states: tuple[tuple[int, State3D], ...]

    def __post_init__(self) -> None:
        if not math.isfinite(self.start_time):
            raise ValueError(f"phase.start_time: expected a finite number, got {self.start_time!r}")
        ids = [box.id for box in self.static_objects]
        if len(set(ids)) != len(ids):
            raise ValueError(f"phase.static_objects: duplicate ids {ids}")
        body_ids = [body_id for body_id, _ in self.states]
        if len(set(body_ids)) != len(body_ids):
            raise ValueError(f"phase.states: duplicate body ids {body_ids}")


@dataclass(frozen=True)
class Anchor3D:
    """Where the factual continuation starts: ``time`` (s, the last observed frame) and every present
    body's fitted state there, as (body_id, State3D) pairs."""

    time: float
    states: tuple[tuple[int, State3D], ...]

    def __post_init__(self) -> None:
        if not (isinstance(self.time, (int, float)) and math.isfinite(self.time) and self.time >= 0):
            raise ValueError(f"anchor.time: expected a finite number >= 0, got {self.time!r}")
        ids = [body_id for body_id, _ in self.states]
        if len(set(ids)) != len(ids):
            raise ValueError(f"anchor.states: duplicate body ids {ids}")


FITTED_KINDS: tuple[str, ...] = ("friction", "impact_friction", "restitution", "impact_duration", "mass_ratio",
                                 "pair_restitution")


@dataclass(frozen=True)
class FittedProperty:
    """One identified latent property the world rests on: ``kind`` (FITTED_KINDS) of ``object_id``
    (mass_ratio, pair_restitution: of ``other_object_id`` relative to ``object_id``), its value,
    one standard deviation and the number of measurements combined."""

    kind: str
    object_id: int
    value: float
    std: float
    measurements: int = 1
    other_object_id: int | None = None

    def __post_init__(self) -> None:
        if self.kind not in FITTED_KINDS:
            raise ValueError(f"fitted property kind: expected one of {FITTED_KINDS}, got {self.kind!r}")
        for name in ("value", "std"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value)):
                raise ValueError(f"fitted property {self.kind}.{name}: expected a finite number, got {value!r}")

    def describe(self) -> str:
        """e.g. 'restitution of object 0 = 0.512 +- 0.004'."""
        pair = f"/{self.other_object_id}" if self.other_object_id is not None else ""
        return f"{self.kind} of object {self.object_id}{pair} = {self.value:.3f} +- {self.std:.3f}"


@dataclass(frozen=True)
class World3D:
    """Bodies with their latent properties, and phases separated by curtains (at least one).

    The properties (mass, friction, restitution) carry over every curtain;
    positions and velocities do not: each phase lists its own initial states.
    pair_restitution: optional ((id_a, id_b), e) overrides of the body-body
    coefficient (default sqrt(e_a e_b)). patient_zone: id of a static zone
    playing the patient, or None.
    """

    bodies: tuple[Body3D, ...]
    phases: tuple[Phase3D, ...]
    gravity: float = STANDARD_GRAVITY
    pair_restitution: tuple[tuple[tuple[int, int], float], ...] = ()
    patient_zone: int | None = None
    provenance: Mapping[str, object] = field(default_factory=dict)
    fps: float = 25.0
    anchor: Anchor3D | None = None
    horizon_frames: int | None = None
    fitted: tuple[FittedProperty, ...] = ()

    def __post_init__(self) -> None:
        ids = [body.id for body in self.bodies]
        if len(set(ids)) != len(ids):
            raise ValueError(f"world.bodies: duplicate ids {ids}")
        if not self.phases:
            raise ValueError("world.phases: expected at least one phase")
        starts = [phase.start_time for phase in self.phases]
        if any(b <= a for a, b in zip(starts, starts[1:])):
            raise ValueError(f"world.phases: start times must increase, got {starts}")
        for phase in self.phases:
            unknown = [body_id for body_id, _ in phase.states if body_id not in ids]
            if unknown:
                raise ValueError(f"phase at t={phase.start_time}: states of unknown bodies {unknown}")
        if not (math.isfinite(self.gravity) and self.gravity > 0):
            raise ValueError(f"world.gravity: expected a number > 0, got {self.gravity!r}")
        for (a, b), e in self.pair_restitution:
            if a not in ids or b not in ids or not 0.0 <= e <= 1.0:
                raise ValueError(f"world.pair_restitution: bad entry ({a}, {b}) -> {e!r}")
        if self.patient_zone is not None:
            zones = [box.id for box in self.phases[-1].static_objects if box.role == "zone"]
            if self.patient_zone not in zones:
                raise ValueError(f"world.patient_zone: {self.patient_zone!r} is not a zone of the last phase {zones}")
        if not (isinstance(self.fps, (int, float)) and math.isfinite(self.fps) and self.fps > 0):
            raise ValueError(f"world.fps: expected a number > 0, got {self.fps!r}")
        if self.anchor is not None:
            unknown = [body_id for body_id, _ in self.anchor.states if body_id not in ids]
            if unknown:
                raise ValueError(f"world.anchor: states of unknown bodies {unknown}")
            if self.anchor.time < self.phases[-1].start_time:
                raise ValueError(f"world.anchor.time: {self.anchor.time} is before the last phase starts ({self.phases[-1].start_time})")
        if self.horizon_frames is not None and (not isinstance(self.horizon_frames, int) or self.horizon_frames < 1):
            raise ValueError(f"world.horizon_frames: expected an integer >= 1 or None, got {self.horizon_frames!r}")

    @property
    def start_time(self) -> float:
        """Where the factual continuation starts (s): the anchor, else the last phase's start."""
        return self.anchor.time if self.anchor is not None else self.phases[-1].start_time

    @property
    def start_states(self) -> dict[int, State3D]:
        """{body_id: State3D} the factual continuation starts from."""
        return dict(self.anchor.states if self.anchor is not None else self.phases[-1].states)

    @property
    def observed_frames(self) -> int:
        """Frames of the video the world was fitted on: up to and including the start of the continuation."""
        return frame_of(self.start_time, self.fps) + 1

    def static_object(self, static_id: int) -> StaticBox | None:
        """A static box of the last phase (where the continuation runs), None if there is none with that id."""
        return next((box for box in self.phases[-1].static_objects if box.id == static_id), None)

    def body(self, body_id: int) -> Body3D:
        for body in self.bodies:
            if body.id == body_id:
                return body
        raise ValueError(f"body id {body_id!r}: not in this world")

    def role(self, role: str) -> Body3D | None:
        matches = [body for body in self.bodies if body.role == role]
        return matches[0] if matches else None


@dataclass(frozen=True)
class PhaseTracks:
    """Observed tracks of one phase.

    times: (T,) s, increasing; body_ids: (N,); positions, velocities: (T, N, 3)
    m and m/s (NaN where a body is not seen); static_objects: the phase's geometry.
    Velocities may be all NaN (positions alone are enough to identify).
    """

    times: np.ndarray
    body_ids: tuple[int, ...]
    positions: np.ndarray
    velocities: np.ndarray
    static_objects: tuple[StaticBox, ...]

    def __post_init__(self) -> None:
        times = np.asarray(self.times, float)
        count = len(self.body_ids)
        if times.ndim != 1 or len(times) < 1 or np.any(np.diff(times) <= 0):
            raise ValueError("tracks.times: expected an increasing (T,) array")
        for name in ("positions", "velocities"):
            array = np.asarray(getattr(self, name), float)
            if array.shape != (len(times), count, 3):
                raise ValueError(f"tracks.{name}: expected shape {(len(times), count, 3)}, got {array.shape}")
            object.__setattr__(self, name, array)
        object.__setattr__(self, "times", times)


@dataclass(frozen=True)
class Tracks3D:
    """Everything observed of a trial: bodies (shape, size, role; properties unknown) and one PhaseTracks per phase."""

    bodies: tuple[Body3D, ...]
    phases: tuple[PhaseTracks, ...]
    patient_zone: int | None = None
    gravity: float = STANDARD_GRAVITY

    def __post_init__(self) -> None:
        if not self.phases:
            raise ValueError("tracks.phases: expected at least one phase")
        known = {body.id for body in self.bodies}
        for phase in self.phases:
            missing = set(phase.body_ids) - known
            if missing:
                raise ValueError(f"tracks: phase lists unknown bodies {sorted(missing)}")
