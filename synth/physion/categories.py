"""Seeded samplers of the five Physion++-style categories.

Each layout is drawn with both classes of the latent property (low/high
friction or restitution, light/heavy mass) and placed so that one class, the
*target*, leads to contact. The trial takes the target class when the wanted
label is true and the other class otherwise; MuJoCo then decides the label
(a draw whose MuJoCo label differs from the wanted one, touches before the
prediction boundary, or is not robust to a 3 cm change of the patient is
redrawn; so is one whose label changes when the property changes by 4 %,
and, for the first half of the draws, one whose label would not
flip with the other class). Placements use the analytic engine only to aim; truth is MuJoCo's.
Units: m, s, kg. Body ids: 0 the red agent, 1 the yellow patient, 2 the blue probe.
Static ids start at 100 (100 is the floor).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from synth.physion.mujoco_run import outcome, run_trial
from synth.physion.spec import FPS, PhaseSpec, TrialSpec
from synth.scene import camera_look_at
from world.scene3d.rollout import simulate3d
from world.scene3d.types import Body3D, Phase3D, State3D, StaticBox, World3D
from world.types import STANDARD_GRAVITY as G

HALF = 0.1  # m: cube half side and sphere radius of every dynamic body
FRICTION_CLASSES = {"collision": ((0.08, 0.16), (0.38, 0.5)), "platform": ((0.08, 0.16), (0.3, 0.42))}
RESTITUTION_CLASSES = ((0.3, 0.45), (0.68, 0.85))
MASS_CLASSES = ((0.3, 0.5), (2.2, 3.5))  # blue probe mass, kg, against the 1 kg red agent
CURTAIN_FRAMES = 10  # 0.4 s of curtain between the phases
MAX_ATTEMPTS = 80
LANDING_GRACE = 0.25  # s: bounce trials end this long after the later class's first floor landing
PROPERTY_NUDGE = 0.04  # relative change of the latent property the label must survive


def floor() -> StaticBox:
    return StaticBox(100, "floor", (0.0, 0.0, -0.25), (15.0, 15.0, 0.25))


def _camera(rng: np.random.Generator, target: tuple[float, float, float]):
    eye = np.array(target) + np.array([rng.uniform(-0.3, 0.3), -rng.uniform(6.5, 7.5), rng.uniform(2.0, 2.8)])
    return camera_look_at(eye, np.array(target, float), 40.0)


def _y_rotation(angle: float) -> tuple[float, float, float, float]:
    """Quaternion (x, y, z, w) of a rotation by ``angle`` rad about +y (tilts +x downwards)."""
    return (0.0, math.sin(angle / 2.0), 0.0, math.cos(angle / 2.0))


@dataclass(frozen=True)
class Layout:
    """A drawn layout: build(value) makes the trial; low/high are the class values; target_low says which class touches."""

    build: Callable[[float], TrialSpec]
    low: float
    high: float
    target_low: bool


def _first_floor_landing(bodies, statics, state: State3D, t0: float, after_static: int | None = None) -> tuple[float, float] | None:
    """x (m) and time (s) of a sphere's first floor impact (after it has hit ``after_static``), by the analytic engine."""
    phase = Phase3D(t0, statics, ((0, state),))
    rollout = simulate3d(World3D(bodies, (phase,)), phase, t0 + 3.0)
    seen = after_static is None
    for event in rollout.events:
        if event.kind == "surface" and event.static_id == after_static:
            seen = True
        elif seen and event.kind == "surface" and event.static_id == 100:
            return float(rollout.state(0, event.time).position[0]), float(event.time)
    return None


def _landing_horizon(restitutions: tuple[float, float], statics, state: State3D, t0: float, after_static: int | None,
                     fallback: float) -> int:
    """Horizon frame: a little after the later of the two classes' first floor landings (the question's window)."""
    times = []
    for e in restitutions:
        landing = _first_floor_landing((Body3D(0, "sphere", HALF, restitution=e),), statics, state, t0, after_static)
        times.append(landing[1] if landing else fallback)
    return int(math.ceil((max(times) + LANDING_GRACE) * FPS))


def _mass_collision(rng: np.random.Generator, index: int) -> Layout:
    e_pair = rng.uniform(0.55, 0.8)
    light, heavy = rng.uniform(*MASS_CLASSES[0]), rng.uniform(*MASS_CLASSES[1])
    yo = rng.uniform(-0.3, 0.3)
    v1, x_blue = rng.uniform(1.0, 1.5), rng.uniform(-0.3, 0.0)
    x_r, d, v2, s = rng.uniform(-0.2, 0.2), rng.uniform(0.7, 0.9), rng.uniform(1.6, 2.4), rng.uniform(0.0, 0.08)
    push = lambda m: (1.0 + e_pair) * m / (m + 1.0) * v2  # noqa: E731  red's speed after the push
    t_c = (d - 2 * HALF) / v2
    t_land = t_c + (2 * HALF + s) / math.sqrt(push(light) * push(heavy))
    z0 = 3 * HALF + 2 * HALF + 0.5 * G * t_land**2 - 2 * HALF  # yellow bottom meets the red top at t_land
    camera = _camera(rng, (0.0, 0.0, 0.7))
    p1 = PhaseSpec(0, 34, (floor(),), ((0, State3D((-1.3, yo, HALF), (v1, 0, 0))), (2, State3D((x_blue, yo, HALF)))))
    p2 = PhaseSpec(45, 0, (floor(),), ((0, State3D((x_r, yo, HALF))), (2, State3D((x_r - d, yo, HALF), (v2, 0, 0))),
                                       (1, State3D((x_r + s, yo, z0)))))
    horizon = 45 + int(round((t_land + 0.8) * FPS))
    p2 = PhaseSpec(45, horizon, p2.static_objects, p2.states)

    def build(mass: float) -> TrialSpec:
        bodies = (Body3D(0, "cube", HALF, 1.0, role="agent", color="red"),
                  Body3D(1, "cube", HALF, 1.0, role="patient", color="yellow"),
                  Body3D(2, "cube", HALF, mass, color="blue"))
        return TrialSpec("mass_collision", index, bodies, (p1, p2), (35, 44), 49, horizon, camera, "mass", 2,
                         swapped_value=heavy if mass == light else light, pair_restitution=e_pair)

    return Layout(build, light, heavy, target_low=True)


def _friction_collision(rng: np.random.Generator, index: int) -> Layout:
    low, high = rng.uniform(*FRICTION_CLASSES["collision"][0]), rng.uniform(*FRICTION_CLASSES["collision"][1])
    target_low = bool(rng.integers(2))
    yo = rng.uniform(-0.3, 0.3)
    v1, x0, v0, t_land = rng.uniform(2.2, 2.8), -1.3, rng.uniform(1.8, 2.4), rng.uniform(0.55, 0.7)
    mu = low if target_low else high
    t_stop = v0 / (mu * G)
    travelled = v0 * t_land - 0.5 * mu * G * t_land**2 if t_land < t_stop else v0**2 / (2 * mu * G)
    x_p = x0 + travelled + rng.uniform(-0.04, 0.04)
    z0 = 3 * HALF + 0.5 * G * t_land**2
    camera = _camera(rng, (-0.2, 0.0, 0.9))
    p1 = PhaseSpec(0, 29, (floor(),), ((0, State3D((-1.6, yo, HALF), (v1, 0, 0))),))
    horizon = 40 + int(round((t_land + 0.8) * FPS))
    p2 = PhaseSpec(40, horizon, (floor(),), ((0, State3D((x0, yo, HALF), (v0, 0, 0))), (1, State3D((x_p, yo, z0)))))

    def build(friction: float) -> TrialSpec:
        bodies = (Body3D(0, "cube", HALF, 1.0, friction=friction, role="agent", color="red"),
                  Body3D(1, "cube", HALF, 1.0, friction=0.3, role="patient", color="yellow"))
        return TrialSpec("friction_collision", index, bodies, (p1, p2), (30, 39), 44, horizon, camera, "friction", 0,
                         swapped_value=high if friction == low else low, pair_restitution=0.5)

    return Layout(build, low, high, target_low)


def _friction_platform(rng: np.random.Generator, index: int) -> Layout:
    low, high = rng.uniform(*FRICTION_CLASSES["platform"][0]), rng.uniform(*FRICTION_CLASSES["platform"][1])
    theta = math.radians(rng.uniform(28.0, 34.0))
    h_p, s0, yo = 0.3, rng.uniform(0.9, 1.1), rng.uniform(-0.2, 0.2)
    quat = _y_rotation(theta)
    down_slope = np.array([math.cos(theta), 0.0, -math.sin(theta)])
    normal = np.array([math.sin(theta), 0.0, math.cos(theta)])
    edge = np.array([0.0, 0.0, h_p])
    ramp_center = edge - (0.7 * down_slope + 0.05 * normal)
    ramp = StaticBox(101, "ramp", ramp_center, (0.7, 0.6, 0.05), quat)
    platform = StaticBox(102, "platform", (1.75, 0.0, h_p / 2), (1.75, 0.6, h_p / 2))
    start = edge - s0 * down_slope + (HALF + 5e-4) * normal + np.array([0.0, yo, 0.0])

    def stop_x(mu: float) -> float:
        # centre reaches the platform's offset plane, loses its normal speed there, then slides to rest
        along = (start[2] - (h_p + HALF)) / math.sin(theta)
        v_b = math.sqrt(2 * G * (math.sin(theta) - mu * math.cos(theta)) * along)
        x_land = start[0] + along * math.cos(theta)
        return x_land + (v_b * math.cos(theta)) ** 2 / (2 * mu * G)

    near, far = stop_x(high) + HALF, stop_x(low) + HALF
    x_zone = near + (far - near) * rng.uniform(0.35, 0.65)
    zone = StaticBox(103, "zone", (x_zone + 0.2, yo, h_p + 0.001), (0.2, 0.3, 0.001))
    camera = _camera(rng, (0.9, 0.0, 0.5))
    statics = (floor(), ramp, platform, zone)
    phase = PhaseSpec(0, 90, statics, ((0, State3D(start)),), ((0, quat),))

    def build(friction: float) -> TrialSpec:
        bodies = (Body3D(0, "cube", HALF, 1.0, friction=friction, role="agent", color="red"),)
        return TrialSpec("friction_platform", index, bodies, (phase,), None, 12, 90, camera, "friction", 0,
                         swapped_value=high if friction == low else low, patient_zone=103)

    return Layout(build, low, high, target_low=True)


def _bounce_platform(rng: np.random.Generator, index: int) -> Layout:
    low, high = rng.uniform(*RESTITUTION_CLASSES[0]), rng.uniform(*RESTITUTION_CLASSES[1])
    target_low = bool(rng.integers(2))
    # fast enough that the vertical phase at the platform edge (set by e) moves the landing by decimetres
    x_e, z0, vx, yo = rng.uniform(0.4, 0.8), rng.uniform(1.0, 1.3), rng.uniform(1.6, 2.4), rng.uniform(-0.2, 0.2)
    platform = StaticBox(101, "platform", (x_e - 1.0, 0.0, 0.2), (1.0, 0.6, 0.2))
    start = State3D((x_e - 1.8, yo, z0), (vx, 0.0, 0.0))
    target = Body3D(0, "sphere", HALF, restitution=low if target_low else high)
    landing = _first_floor_landing((target,), (floor(), platform), start, 0.0)
    x_land = landing[0] if landing else x_e + 0.5
    zone = StaticBox(102, "zone", (x_land + rng.uniform(-0.04, 0.04), yo, 0.001), (0.12, 0.3, 0.001))
    t1 = math.sqrt(2 * (z0 - 0.5) / G)
    boundary = int(math.ceil((t1 + 0.28) * FPS))
    horizon = max(boundary + 5, _landing_horizon((low, high), (floor(), platform), start, 0.0, None, 3.0))
    camera = _camera(rng, (x_e - 0.6, 0.0, 0.5))
    phase = PhaseSpec(0, horizon, (floor(), platform, zone), ((0, start),))

    def build(restitution: float) -> TrialSpec:
        bodies = (Body3D(0, "sphere", HALF, 1.0, restitution=restitution, role="agent", color="red"),)
        return TrialSpec("bounce_platform", index, bodies, (phase,), None, boundary, horizon, camera, "restitution", 0,
                         swapped_value=high if restitution == low else low, patient_zone=102)

    return Layout(build, low, high, target_low)


def _bounce_wall(rng: np.random.Generator, index: int) -> Layout:
    low, high = rng.uniform(*RESTITUTION_CLASSES[0]), rng.uniform(*RESTITUTION_CLASSES[1])
    target_low = bool(rng.integers(2))
    x_w, yo = 1.0, rng.uniform(-0.2, 0.2)
    wall = StaticBox(101, "wall", (x_w, 0.0, 0.6), (0.1, 0.8, 0.6))
    first = State3D((x_w - 1.4, yo, rng.uniform(0.6, 0.9)), (rng.uniform(2.5, 3.2), 0.0, rng.uniform(1.5, 2.2)))
    second = State3D((x_w - rng.uniform(0.9, 1.4), yo, rng.uniform(0.5, 0.8)), (rng.uniform(2.4, 3.2), 0.0, rng.uniform(1.5, 2.5)))
    target = Body3D(0, "sphere", HALF, restitution=low if target_low else high)
    landing = _first_floor_landing((target,), (floor(), wall), second, 0.0, after_static=101)
    x_land = landing[0] if landing else x_w - 1.0
    horizon = 50 + _landing_horizon((low, high), (floor(), wall), second, 0.0, 101, 1.8)
    camera = _camera(rng, (x_w - 1.0, 0.0, 0.6))
    p1 = PhaseSpec(0, 39, (floor(), wall), ((0, first),))
    zone = StaticBox(102, "zone", (x_land + rng.uniform(-0.05, 0.05), yo, 0.001), (0.15, 0.3, 0.001))
    p2 = PhaseSpec(50, horizon, (floor(), wall, zone), ((0, second),))

    def build(restitution: float) -> TrialSpec:
        bodies = (Body3D(0, "sphere", HALF, 1.0, restitution=restitution, role="agent", color="red"),)
        return TrialSpec("bounce_wall", index, bodies, (p1, p2), (40, 49), 54, horizon, camera, "restitution", 0,
                         swapped_value=high if restitution == low else low, patient_zone=102)

    return Layout(build, low, high, target_low)


SAMPLERS: dict[str, Callable[[np.random.Generator, int], Layout]] = {
    "mass_collision": _mass_collision, "friction_collision": _friction_collision,
    "friction_platform": _friction_platform, "bounce_platform": _bounce_platform, "bounce_wall": _bounce_wall,
}


@dataclass(frozen=True)
class SampledTrial:
    trial: TrialSpec
    runs: list
    label: bool
    contact_time: float | None
    swapped_label: bool
    attempts: int

    @property
    def label_flips(self) -> bool:
        return self.label != self.swapped_label


def sample_trial(category: str, rng: np.random.Generator, index: int, want_label: bool) -> SampledTrial:
    """Draw layouts until MuJoCo gives ``want_label`` robustly with no touch before the boundary.

    The first half of the draws also require the label to flip when the property is swapped
    (Physion++'s matched pairs); later draws accept a trial whose label does not flip.
    """
    for attempt in range(1, MAX_ATTEMPTS + 1):
        layout = SAMPLERS[category](rng, index)
        target = layout.low if layout.target_low else layout.high
        other = layout.high if layout.target_low else layout.low
        trial = layout.build(target if want_label else other)
        runs = run_trial(trial)
        result = outcome(trial, runs)
        if result.label != want_label or result.touched_before_boundary or not result.robust:
            continue
        value = trial.property_value
        if any(outcome(nudged, run_trial(nudged)).label != result.label
               for nudged in (trial.with_property(value * (1 - PROPERTY_NUDGE)), trial.with_property(value * (1 + PROPERTY_NUDGE)))):
            continue  # a knife-edge outcome: MuJoCo's own answer flips with a 4 % change of the property
        swapped = outcome(trial, run_trial(trial.with_property(trial.swapped_value)))
        if swapped.label == result.label and attempt <= MAX_ATTEMPTS // 2:
            continue
        return SampledTrial(trial, runs, result.label, result.contact_time, swapped.label, attempt)
    raise RuntimeError(f"{category} trial {index}: no layout gave label {want_label} in {MAX_ATTEMPTS} draws")
