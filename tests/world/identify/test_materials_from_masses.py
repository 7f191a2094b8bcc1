"""Material beliefs revised by identified mass ratios (world/identify/materials.py).

The law: metal is denser than rubber (FitConfig.density_prior), so a collision
that identifies two bodies' mass ratio says which materials they can be. The
pair's motion comes from MuJoCo (the generator's model, bench/pair_mujoco.py);
perception's belief is made uncertain on purpose.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from bench.pair_mujoco import pair_spec, run_pair
from world.identify.fit import FitConfig, identify
from world.identify.materials import MAX_LINK_RMSE, prior_mass, revise_materials, shape_volume
from world.observations import Observations
from world.types import AttributeBelief, Body, BodyState, World
from tests.world.identify.cylinder_tracks import CYLINDER, cylinder_track

DENSITY = FitConfig().density_prior


def _belief(p_metal: float) -> AttributeBelief:
    return AttributeBelief.from_mappings({"red": 1.0}, {"metal": p_metal, "rubber": 1.0 - p_metal}, {"cylinder": 1.0}, 50)


def _mujoco_pair(mass_ratio: float, beliefs: tuple[float, float], config: FitConfig = FitConfig(), seconds: float = 3.0):
    """Cylinder 0 launched into cylinder 1 (mass_ratio x its density) at rest; identify from the exact tracks."""
    truth = run_pair(pair_spec(("cylinder", "cylinder"), speed=1.6, offset=0.05, frictions=(0.08, 0.08), mass_ratio=mass_ratio), seconds)
    n = truth.positions.shape[0]
    frames = np.arange(n)

    tracks = tuple(cylinder_track(b, frames, truth.positions[:, b], "metal" if beliefs[b] > 0.5 else "rubber", _belief(beliefs[b]))
                   for b in (0, 1))
    return identify(Observations(tracks, truth.fps, n, None), config)


def _p_metal(world: World, body_id: int) -> float:
    body = next(b for b in world.bodies if b.id == body_id)
    return body.attribute_belief.distribution("material")["metal"]


@pytest.mark.parametrize("mass_ratio", [2.5, 3.5])
def test_the_heavier_of_two_undecided_bodies_is_judged_metal(mass_ratio):
    # Perception cannot tell (0.5 each); MuJoCo's struck body is 2.5-3.5x denser.
    world, report = _mujoco_pair(mass_ratio, (0.5, 0.5))
    assert _p_metal(world, 1) > 0.8 and _p_metal(world, 0) < 0.2
    assert [b.material for b in sorted(world.bodies, key=lambda b: b.id)] == ["rubber", "metal"]
    struck = next(o for o in report.objects if o.id == 1)
    assert any("material from mass ratios with bodies [0]" in flag for flag in struck.flags)


def test_the_lighter_striker_is_judged_rubber_against_a_wrong_appearance():
    # Appearance leans the wrong way (striker metal 0.65, struck rubber 0.6); the struck body is 3x denser.
    world, _ = _mujoco_pair(3.0, (0.65, 0.4))
    assert _p_metal(world, 0) < 0.5 < _p_metal(world, 1)


def test_equal_densities_pull_an_uncertain_body_to_its_partners_material():
    world, _ = _mujoco_pair(1.0, (0.9, 0.35))
    assert _p_metal(world, 1) > 0.5
    assert _p_metal(world, 0) > 0.8


def test_off_keeps_perceptions_beliefs():
    world, _ = _mujoco_pair(3.0, (0.5, 0.5), FitConfig(materials_from_masses=False))
    assert _p_metal(world, 0) == pytest.approx(0.5) and _p_metal(world, 1) == pytest.approx(0.5)


def _body(body_id: int, mass: float, p_metal: float | None, material: str = "rubber") -> Body:
    return Body(body_id, CYLINDER, BodyState((0.0, 0.0, 0.2)), mass=mass, friction=0.1, restitution=0.7, color="red",
                material=material, attribute_belief=None if p_metal is None else _belief(p_metal))


def _world(*bodies: Body) -> World:
    return World(bodies=tuple(bodies), fps=25.0, observed_frames=10)


def test_bodies_without_a_belief_or_a_link_are_left_alone():
    volume = shape_volume(CYLINDER)
    world = _world(_body(0, 1100 * volume, None), _body(1, 2700 * volume, 0.5), _body(2, 2700 * volume, 0.5))
    revised, revisions = revise_materials(world, [(0, 1)], DENSITY)
    assert revisions == () and revised == world


def test_a_changed_material_rescales_its_group_and_keeps_the_mass_ratio():
    volume = shape_volume(CYLINDER)
    # Fitted ratio 2.45 with both bodies taken as rubber: the heavier becomes metal.
    world = _world(_body(0, 1100 * volume, 0.45), _body(1, 2700 * volume, 0.45))
    revised, revisions = revise_materials(world, [(0, 1)], DENSITY, mass_groups=[(0, 1)])
    masses = {b.id: b.mass for b in revised.bodies}
    assert {b.id: b.material for b in revised.bodies} == {0: "rubber", 1: "metal"}
    assert masses[1] / masses[0] == pytest.approx(2700 / 1100)
    # The group's geometric mean follows its priors: rubber + metal instead of rubber + rubber.
    expected_shift = math.sqrt(prior_mass(CYLINDER, "metal", DENSITY) / prior_mass(CYLINDER, "rubber", DENSITY))
    assert masses[0] == pytest.approx(1100 * volume * expected_shift)
    assert {r.body for r in revisions} == {0, 1}


def test_a_link_from_a_fit_that_misses_the_tracks_is_no_evidence():
    volume = shape_volume(CYLINDER)
    world = _world(_body(0, 1100 * volume, 0.5), _body(1, 2700 * volume, 0.5))
    _, trusted = revise_materials(world, [(0, 1)], DENSITY, rmse={0: 0.01, 1: 0.02})
    assert {r.body: round(r.after["metal"], 2) > 0.8 for r in trusted} == {0: False, 1: True}
    ignored, none = revise_materials(world, [(0, 1)], DENSITY, rmse={0: 0.01, 1: 2.0 * MAX_LINK_RMSE})
    assert none == () and ignored == world
