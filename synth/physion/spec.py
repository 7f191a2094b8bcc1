"""The description of one Physion-style trial (no physics, no rendering).

Frames are at FPS; phase k covers frames [first_frame, last_frame] and starts
at time first_frame / FPS from its listed states. The last phase is observed
up to ``boundary_frame`` and simulated on to ``horizon_frame``.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from synth.mjcf import CONTACT_HALF_PERIOD
from world.scene3d.types import Body3D, Phase3D, State3D, StaticBox, World3D
from world.types import Camera

FPS = 25.0
CATEGORIES: tuple[str, ...] = ("mass_collision", "friction_collision", "friction_platform", "bounce_platform", "bounce_wall")
CATEGORY_TITLES: dict[str, str] = {
    "mass_collision": "Mass Coll.", "friction_collision": "Fric. Coll.", "friction_platform": "Fric. Plat.",
    "bounce_platform": "Bounce Plat.", "bounce_wall": "Bounce Wall",
}
PROPERTY_KINDS: tuple[str, ...] = ("friction", "restitution", "mass")
QUESTION = "Will the red object contact the yellow object?"


@dataclass(frozen=True)
class PhaseSpec:
    """Static geometry and initial states of one phase; orientations: (body_id, quaternion x y z w)."""

    first_frame: int
    last_frame: int
    static_objects: tuple[StaticBox, ...]
    states: tuple[tuple[int, State3D], ...]
    orientations: tuple[tuple[int, tuple[float, float, float, float]], ...] = ()

    @property
    def start_time(self) -> float:
        return self.first_frame / FPS


@dataclass(frozen=True)
class TrialSpec:
    """One trial: bodies with their properties, phases, curtain, boundary, camera and the latent property.

    property_kind/property_body: which latent property decides the trial
    (friction or restitution of the agent, or the mass of ``property_body``);
    its value is in ``bodies``. swapped_value: the value of the other class
    (the counterpart trial the label-flip flag is measured on).
    """

    category: str
    index: int
    bodies: tuple[Body3D, ...]
    phases: tuple[PhaseSpec, ...]
    curtain_frames: tuple[int, int] | None
    boundary_frame: int
    horizon_frame: int
    camera: Camera
    property_kind: str
    property_body: int
    swapped_value: float
    patient_zone: int | None = None
    pair_restitution: float = 0.0  # body-body coefficient of restitution

    def __post_init__(self) -> None:
        if self.category not in CATEGORIES:
            raise ValueError(f"category: expected one of {CATEGORIES}, got {self.category!r}")
        if self.property_kind not in PROPERTY_KINDS:
            raise ValueError(f"property_kind: expected one of {PROPERTY_KINDS}, got {self.property_kind!r}")
        last = self.phases[-1]
        if not last.first_frame <= self.boundary_frame < self.horizon_frame:
            raise ValueError("boundary_frame: must lie in the last phase and before horizon_frame")

    @property
    def property_value(self) -> float:
        body = next(b for b in self.bodies if b.id == self.property_body)
        return float(getattr(body, self.property_kind))

    def with_property(self, value: float) -> "TrialSpec":
        """The same trial with the latent property set to ``value`` (the other one becomes swapped_value)."""
        old = self.property_value
        bodies = tuple(replace(b, **{self.property_kind: value}) if b.id == self.property_body else b for b in self.bodies)
        return replace(self, bodies=bodies, swapped_value=old)


def world_from_spec(trial: TrialSpec) -> World3D:
    """The analytic world of a trial with its true (MuJoCo parameter) properties, for tests and aiming.

    A bouncing body's impacts last the generator's contact half period.
    """
    bodies = tuple(replace(b, impact_duration=CONTACT_HALF_PERIOD if b.restitution > 0 else 0.0) for b in trial.bodies)
    phases = tuple(Phase3D(p.start_time, p.static_objects, p.states) for p in trial.phases)
    ids = [b.id for b in trial.bodies]
    pairs = tuple(((a, b), trial.pair_restitution) for n, a in enumerate(ids) for b in ids[n + 1:])
    return World3D(bodies, phases, pair_restitution=pairs, patient_zone=trial.patient_zone)
