"""The executable world's data types: frozen dataclasses, no algorithms.

Conventions (see docs/architecture.md):

* SI units. World frame: z up, support plane z = 0, gravity (0, 0, -9.81).
* Time in seconds; a frame index is ``round(t * fps)``.
* Yaw is the rotation about +z in radians; quaternions are (x, y, z, w).
* Object ids are small non-negative integers, as in CLEVRER's ``object_id``.

Algorithms live in sibling modules and are pure functions over these types,
e.g. ``world.rollout.simulate(world, edits) -> Rollout``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal, Mapping

import numpy as np

ShapeKind = Literal["sphere", "cube", "cylinder"]
SHAPE_KINDS: tuple[str, ...] = ("sphere", "cube", "cylinder")
COLORS: tuple[str, ...] = ("gray", "red", "blue", "green", "brown", "yellow", "cyan", "purple")
# CLEVR's public palette (sRGB 0..255): the paint of each colour name, as CLEVRER renders it.
# The generator paints with it; perception uses its chromaticities as colour prototypes.
CLEVR_PALETTE_RGB: dict[str, tuple[int, int, int]] = {
    "gray": (87, 87, 87), "red": (173, 35, 35), "blue": (42, 75, 215), "green": (29, 105, 20),
    "brown": (129, 74, 25), "yellow": (255, 238, 51), "cyan": (41, 208, 208), "purple": (129, 38, 192),
}
MATERIALS: tuple[str, ...] = ("rubber", "metal")
EventKind = Literal["collision", "in", "out", "stop"]
EVENT_KINDS: tuple[str, ...] = ("collision", "in", "out", "stop")
EditKind = Literal[
    "remove_object", "set_velocity", "set_mass", "set_friction", "set_restitution"
]
EDIT_KINDS: tuple[str, ...] = (
    "remove_object",
    "set_velocity",
    "set_mass",
    "set_friction",
    "set_restitution",
)

STANDARD_GRAVITY = 9.81  # m/s^2


def _require(condition: bool, message: str) -> None:
    if not condition:
        raise ValueError(message)


def _finite(value: float) -> bool:
    return isinstance(value, (int, float, np.floating, np.integer)) and math.isfinite(value)


@dataclass(frozen=True)
class Shape:
    """Rigid shape of a body, in metres.

    * sphere: ``radius``.
    * cube: ``half_extent`` (half the side length); the footprint is a square
      rotated by the body's yaw.
    * cylinder (upright, axis along z): ``radius`` and ``half_height``.
    ``mesh_path`` optionally names a mesh file (trimesh-readable) for display
    or finer contact; the analytic engine uses the primitive.
    """

    kind: ShapeKind
    radius: float = 0.0
    half_extent: float = 0.0
    half_height: float = 0.0
    mesh_path: str | None = None

    def __post_init__(self) -> None:
        _require(self.kind in SHAPE_KINDS, f"shape.kind: expected one of {SHAPE_KINDS}, got {self.kind!r}")
        if self.kind in ("sphere", "cylinder"):
            _require(_finite(self.radius) and self.radius > 0, f"shape.radius: must be a finite number > 0 for a {self.kind}, got {self.radius!r}")
        if self.kind == "cylinder":
            _require(_finite(self.half_height) and self.half_height > 0, f"shape.half_height: must be a finite number > 0 for a cylinder, got {self.half_height!r}")
        if self.kind == "cube":
            _require(_finite(self.half_extent) and self.half_extent > 0, f"shape.half_extent: must be a finite number > 0 for a cube, got {self.half_extent!r}")

    @property
    def rest_height(self) -> float:
        """Height (m) of the body's centre above the plane when it rests on it."""
        if self.kind == "sphere":
            return self.radius
        if self.kind == "cube":
            return self.half_extent
        return self.half_height

    @property
    def bounding_radius(self) -> float:
        """Radius (m) of the smallest circle about the centre that holds the footprint."""
        if self.kind == "cube":
            return self.half_extent * math.sqrt(2.0)
        return self.radius

    @property
    def yaw_inertia_per_mass(self) -> float:
        """Moment of inertia about the vertical axis through the centre, per unit mass (m^2).

        Solid sphere 2/5 r^2, solid upright cylinder r^2 / 2, solid cube
        (2h)^2 / 6 = 2/3 h^2 with h the half extent.
        """
        if self.kind == "sphere":
            return 0.4 * self.radius**2
        if self.kind == "cylinder":
            return 0.5 * self.radius**2
        return 2.0 / 3.0 * self.half_extent**2

    @property
    def footprint_mean_radius(self) -> float:
        """Mean distance (m) of the points of the face it slides on from the centre
        (the arm of the floor's friction torque on a body spinning in place, uniform pressure).

        Cube: square of half side h, ``h (sqrt 2 + ln(1 + sqrt 2)) / 3``; cylinder: disc, ``2 r / 3``;
        sphere: 0 (it touches the plane at a point).
        """
        if self.kind == "sphere":
            return 0.0
        if self.kind == "cylinder":
            return 2.0 / 3.0 * self.radius
        return self.half_extent * (math.sqrt(2.0) + math.log1p(math.sqrt(2.0))) / 3.0


@dataclass(frozen=True)
class BodyState:
    """Kinematic state of one body at ``time``.

    position: (3,) float64, metres, world frame (z is the centre's height).
    velocity: (3,) float64, m/s.
    yaw: radians about +z; yaw_rate: rad/s.
    spin_velocity: (2,) m/s or None, for a sphere with a rolling model
    (``Body.rolling_friction``): the planar velocity of rolling without slip
    at its spin, ``(omega x r e_z)_xy``. None: it rolls (equal to the planar
    velocity); (0, 0): no spin, so it skids first.
    """

    position: tuple[float, float, float]
    velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    yaw: float = 0.0
    yaw_rate: float = 0.0
    time: float = 0.0
    spin_velocity: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        for name in ("position", "velocity"):
            value = getattr(self, name)
            _require(len(value) == 3 and all(_finite(v) for v in value), f"{name}: expected 3 finite numbers, got {value!r}")
            object.__setattr__(self, name, tuple(float(v) for v in value))
        for name in ("yaw", "yaw_rate", "time"):
            _require(_finite(getattr(self, name)), f"{name}: expected a finite number, got {getattr(self, name)!r}")
        _require(self.time >= 0, f"time: must be >= 0, got {self.time!r}")
        if self.spin_velocity is not None:
            _require(len(self.spin_velocity) == 2 and all(_finite(v) for v in self.spin_velocity),
                     f"spin_velocity: expected 2 finite numbers or None, got {self.spin_velocity!r}")
            object.__setattr__(self, "spin_velocity", tuple(float(v) for v in self.spin_velocity))


# Attribute vocabulary per attribute name (the keys of an AttributeBelief).
ATTRIBUTE_VALUES: dict[str, tuple[str, ...]] = {"color": COLORS, "material": MATERIALS, "shape": SHAPE_KINDS}
BELIEF_SUM_TOLERANCE = 1e-6  # a distribution's probabilities must sum to 1 within this


@dataclass(frozen=True)
class AttributeBelief:
    """What perception believes about one object's attributes: a probability per value.

    color / material / shape: ((value, p), ...) over the attribute's vocabulary
    (ATTRIBUTE_VALUES; values left out have p = 0), each p in [0, 1], summing
    to 1. Build it with :meth:`from_mappings`. support_frames: frames the object
    was seen in (>= 0), which tells a real object from a short duplicate track.
    """

    color: tuple[tuple[str, float], ...]
    material: tuple[tuple[str, float], ...]
    shape: tuple[tuple[str, float], ...]
    support_frames: int = 0

    @classmethod
    def from_mappings(cls, color: Mapping[str, float], material: Mapping[str, float], shape: Mapping[str, float],
                      support_frames: int = 0) -> "AttributeBelief":
        return cls(tuple(color.items()), tuple(material.items()), tuple(shape.items()), support_frames)

    def __post_init__(self) -> None:
        for name, vocabulary in ATTRIBUTE_VALUES.items():
            pairs = getattr(self, name)
            _require(isinstance(pairs, tuple) and len(pairs) > 0, f"attribute_belief.{name}: expected (value, p) pairs, got {pairs!r}")
            values = [pair[0] for pair in pairs]
            _require(all(v in vocabulary for v in values), f"attribute_belief.{name}: values must be among {vocabulary}, got {values}")
            _require(len(set(values)) == len(values), f"attribute_belief.{name}: a value is listed twice: {values}")
            probabilities = [pair[1] for pair in pairs]
            _require(all(_finite(p) and 0 <= p <= 1 for p in probabilities), f"attribute_belief.{name}: probabilities must be in [0, 1], got {probabilities}")
            _require(abs(sum(probabilities) - 1.0) <= BELIEF_SUM_TOLERANCE, f"attribute_belief.{name}: probabilities must sum to 1, got {sum(probabilities)!r}")
            object.__setattr__(self, name, tuple((str(v), float(p)) for v, p in pairs))
        _require(isinstance(self.support_frames, (int, np.integer)) and not isinstance(self.support_frames, bool) and self.support_frames >= 0,
                 f"attribute_belief.support_frames: expected an integer >= 0, got {self.support_frames!r}")
        object.__setattr__(self, "support_frames", int(self.support_frames))

    def distribution(self, name: str) -> dict[str, float]:
        """value -> p of one attribute ("color", "material", "shape"); values not listed have p = 0."""
        return dict(getattr(self, name))


@dataclass(frozen=True)
class Body:
    """One rigid object of a world.

    ``initial`` is the body's state when it becomes active (``initial.time``,
    seconds; 0 for bodies present from the start, later for bodies that enter
    the world part-way). ``active_until`` (seconds) removes it afterwards;
    None keeps it to the end of any rollout.
    mass: kg (> 0); friction: Coulomb coefficient with the plane (> 0);
    restitution: default coefficient for its collisions, in [0, 1].
    rolling_friction: spheres only, optional: the sphere rolls (docs/engine.md,
    "Flows"): it decelerates at ``rolling_friction * g`` while rolling, and
    ``friction`` is then its kinetic (skid) friction while its contact point
    slips, e.g. after a collision. None: it slides at ``friction * g`` like
    any other body (worlds written before the rolling model).
    contact_friction: optional Coulomb coefficient of its surface against
    other bodies (>= 0); a pair's friction is the mean of the two
    (``world.contacts.pair_friction``), None counting as 0. None for both:
    frictionless contact between them (worlds written before).
    """

    id: int
    shape: Shape
    initial: BodyState
    mass: float = 1.0
    friction: float = 0.3
    restitution: float = 0.8
    color: str | None = None
    material: str | None = None
    active_until: float | None = None
    rolling_friction: float | None = None
    contact_friction: float | None = None
    attribute_belief: AttributeBelief | None = None  # perception's probabilities per attribute value; None: not perceived

    def __post_init__(self) -> None:
        _require(isinstance(self.id, (int, np.integer)) and not isinstance(self.id, bool) and self.id >= 0, f"body.id: expected an integer >= 0, got {self.id!r}")
        _require(_finite(self.mass) and self.mass > 0, f"body {self.id}: mass must be a finite number > 0, got {self.mass!r}")
        _require(_finite(self.friction) and self.friction > 0, f"body {self.id}: friction (mu) must be a finite number > 0, got {self.friction!r}")
        _require(_finite(self.restitution) and 0 <= self.restitution <= 1, f"body {self.id}: restitution must be in [0, 1], got {self.restitution!r}")
        _require(self.color is None or self.color in COLORS, f"body {self.id}: color: expected one of {COLORS}, got {self.color!r}")
        _require(self.material is None or self.material in MATERIALS, f"body {self.id}: material: expected one of {MATERIALS}, got {self.material!r}")
        _require(self.attribute_belief is None or isinstance(self.attribute_belief, AttributeBelief),
                 f"body {self.id}: attribute_belief: expected an AttributeBelief or None, got {type(self.attribute_belief).__name__}")
        if self.rolling_friction is not None:
            _require(self.shape.kind == "sphere", f"body {self.id}: rolling_friction applies to spheres only, not a {self.shape.kind}")
            _require(_finite(self.rolling_friction) and self.rolling_friction > 0, f"body {self.id}: rolling_friction must be a finite number > 0, got {self.rolling_friction!r}")
        if self.contact_friction is not None:
            _require(_finite(self.contact_friction) and self.contact_friction >= 0, f"body {self.id}: contact_friction must be a finite number >= 0, got {self.contact_friction!r}")
        if self.active_until is not None:
            _require(_finite(self.active_until) and self.active_until > self.initial.time, f"body {self.id}: active_until must be after initial.time, got {self.active_until!r}")

    @property
    def rolls(self) -> bool:
        """Whether the body follows the sphere's skid-then-roll model."""
        return self.rolling_friction is not None

    @property
    def sliding_deceleration_coefficient(self) -> float:
        """Deceleration / g (dimensionless) of its ordinary motion: rolling, or sliding."""
        return self.rolling_friction if self.rolling_friction is not None else self.friction

    @property
    def attributes(self) -> dict[str, str | None]:
        return {"color": self.color, "material": self.material, "shape": self.shape.kind}


@dataclass(frozen=True)
class Camera:
    """Pinhole camera, OpenCV convention (x right, y down, z forward).

    width, height: image size in pixels. fx, fy, cx, cy: intrinsics, pixels.
    position: (3,) camera centre in world frame, metres.
    rotation: (3, 3) row-major rotation taking camera-frame vectors to the
    world frame (columns are the camera axes expressed in world coordinates).
    """

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    position: tuple[float, float, float]
    rotation: tuple[tuple[float, float, float], tuple[float, float, float], tuple[float, float, float]]

    def __post_init__(self) -> None:
        _require(self.width > 0 and self.height > 0, f"camera: width and height must be > 0, got {self.width}x{self.height}")
        _require(all(_finite(v) and v > 0 for v in (self.fx, self.fy)), "camera: fx and fy must be finite numbers > 0")
        rot = np.asarray(self.rotation, dtype=float)
        _require(rot.shape == (3, 3) and np.all(np.isfinite(rot)), "camera.rotation: expected a finite 3x3 matrix")
        _require(np.allclose(rot @ rot.T, np.eye(3), atol=1e-6), "camera.rotation: matrix is not orthonormal")
        object.__setattr__(self, "rotation", tuple(tuple(float(v) for v in row) for row in rot))
        object.__setattr__(self, "position", tuple(float(v) for v in self.position))


@dataclass(frozen=True)
class Anchor:
    """Where the continuation past the observed window starts from.

    A replay from the fitted initial states drifts a little over a long
    video; the state fitted on each body's last observed stretch is closer
    to the truth. At ``time`` (s) the unedited base rollout resets every
    listed body to its ``states`` entry ``(body_id, BodyState)`` and runs on
    from there. Edited rollouts (counterfactuals) ignore the anchor: they
    replay another history from the initial states.
    """

    time: float
    states: tuple[tuple[int, BodyState], ...]

    def __post_init__(self) -> None:
        _require(_finite(self.time) and self.time >= 0, f"anchor.time: must be a finite number >= 0, got {self.time!r}")
        ids = [body_id for body_id, _ in self.states]
        _require(len(ids) == len(set(ids)), f"anchor.states: duplicate body ids {ids}")
        for body_id, state in self.states:
            _require(isinstance(state, BodyState), f"anchor.states[{body_id}]: expected a BodyState")


@dataclass(frozen=True)
class World:
    """A reusable executable world.

    bodies: the objects, each with its initial (entry) state and parameters.
    fps: frame rate of the source video; observed_frames: frames it covered.
    pair_restitution: optional overrides ``((id_a, id_b, e), ...)`` of the
    per-body restitution for a pair (order of ids does not matter).
    camera: optional, needed for in/out-of-view events.
    anchor: optional re-anchoring of the unedited continuation (see Anchor).
    observed_collisions: ``((id_a, id_b, frame), ...)``, ids sorted, the
    collisions seen in the observed video (identification's events, the
    evidence explanatory answers rest on); None when unknown (a world not
    fitted to a video).
    contact_slip_removal: share in [0, 1] of the contact points' tangential
    slip that an impact between two bodies with friction removes, at most
    (``world.contacts.tangential_impulse``): 1 is a rigid contact that sticks;
    the Coulomb limit applies on top.
    provenance: free-form record of where the parameters came from
    (e.g. the fit report); kept JSON-serialisable.
    """

    bodies: tuple[Body, ...]
    fps: float = 25.0
    observed_frames: int = 128
    gravity: float = STANDARD_GRAVITY
    pair_restitution: tuple[tuple[int, int, float], ...] = ()
    camera: Camera | None = None
    id: str = "world"
    provenance: Mapping[str, object] = field(default_factory=dict)
    anchor: Anchor | None = None
    observed_collisions: tuple[tuple[int, int, int], ...] | None = None
    contact_slip_removal: float = 1.0

    def __post_init__(self) -> None:
        ids = [b.id for b in self.bodies]
        _require(_finite(self.contact_slip_removal) and 0 <= self.contact_slip_removal <= 1,
                 f"contact_slip_removal: must be in [0, 1], got {self.contact_slip_removal!r}")
        _require(len(ids) == len(set(ids)), f"bodies: duplicate body ids {sorted({i for i in ids if ids.count(i) > 1})}")
        _require(_finite(self.fps) and self.fps > 0, f"fps: must be > 0, got {self.fps!r}")
        _require(isinstance(self.observed_frames, (int, np.integer)) and self.observed_frames >= 0, f"observed_frames: must be an integer >= 0, got {self.observed_frames!r}")
        _require(_finite(self.gravity) and self.gravity > 0, f"gravity: must be > 0 (magnitude, m/s^2), got {self.gravity!r}")
        known = set(ids)
        for a, b, e in self.pair_restitution:
            _require(a in known and b in known, f"pair_restitution: unknown body id in pair ({a}, {b}); known ids {sorted(known)}")
            _require(_finite(e) and 0 <= e <= 1, f"pair_restitution: e for ({a}, {b}) must be in [0, 1], got {e!r}")
        collisions = []
        for entry in self.observed_collisions or ():
            _require(len(entry) == 3, f"observed_collisions: expected (id_a, id_b, frame), got {entry!r}")
            a, b, frame = (int(v) for v in entry)
            _require(a in known and b in known and a < b, f"observed_collisions: ({a}, {b}) must be two known body ids, ascending; known ids {sorted(known)}")
            _require(0 <= frame < max(self.observed_frames, 1), f"observed_collisions: frame {frame} of ({a}, {b}) is outside the observed frames 0..{self.observed_frames - 1}")
            collisions.append((a, b, frame))
        if self.observed_collisions is not None:
            object.__setattr__(self, "observed_collisions", tuple(sorted(collisions, key=lambda c: (c[2], c[0], c[1]))))
        if self.anchor is not None:
            for body_id, _ in self.anchor.states:
                _require(body_id in known, f"anchor.states: unknown body id {body_id}; known ids {sorted(known)}")

    @property
    def body_ids(self) -> tuple[int, ...]:
        return tuple(b.id for b in self.bodies)

    def body(self, body_id: int) -> Body:
        for b in self.bodies:
            if b.id == body_id:
                return b
        raise KeyError(f"unknown body id {body_id!r}; known ids {list(self.body_ids)}")


@dataclass(frozen=True)
class Event:
    """Something that happened in a rollout.

    kind: collision (two bodies), in / out (one body enters / leaves the
    camera view), stop (one body comes to rest).
    bodies: ids involved, sorted ascending for collisions.
    time: seconds; frame: ``round(time * fps)``.
    position: (3,) world-frame contact point or body position, metres.
    impulse: magnitude of the normal impulse (N s) for collisions, else 0.
    """

    kind: EventKind
    bodies: tuple[int, ...]
    time: float
    frame: int
    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    impulse: float = 0.0


@dataclass(frozen=True)
class Edit:
    """One intervention on a world, applied before replaying it.

    remove_object: ``body``, optional ``from_frame`` (default: the body's
    first active frame). set_velocity: ``value`` = (vx, vy, vz) m/s at the
    body's entry. set_mass / set_friction: ``value`` = scalar.
    set_restitution: ``value`` = scalar e; with ``other`` set, only for the
    pair (body, other).
    """

    kind: EditKind
    body: int
    value: float | tuple[float, ...] | None = None
    other: int | None = None
    from_frame: int | None = None


@dataclass(frozen=True)
class Rollout:
    """The executed world, sampled per frame.

    body_ids: (N,) ids, in the order of the array axes below.
    times: (T,) seconds, ``frame / fps`` for frames 0..T-1.
    positions: (T, N, 3) float64 metres; velocities: (T, N, 3) m/s.
    yaw: (T, N) radians. active: (T, N) bool, body exists in the world.
    visible: (T, N) bool, body centre is inside the camera view (all True
    when the world has no camera).
    events: in time order. horizon_frames: T.
    notes: engine remarks (event cap reached, contacts skipped), usually empty.
    yaw_rates: (T, N) rad/s from the engine's flows; None where not recorded
    (rollouts read from documents, other producers).
    """

    id: str
    world_id: str
    edits: tuple[Edit, ...]
    fps: float
    observed_frames: int
    body_ids: tuple[int, ...]
    times: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray
    yaw: np.ndarray
    active: np.ndarray
    visible: np.ndarray
    events: tuple[Event, ...]
    # Engine remarks worth surfacing (e.g. the event cap was reached); empty normally.
    notes: tuple[str, ...] = ()
    yaw_rates: np.ndarray | None = None

    @property
    def horizon_frames(self) -> int:
        return int(self.times.shape[0])
