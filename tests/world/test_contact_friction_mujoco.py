"""Friction between bodies at impacts: the closed-form law, and the law against MuJoCo.

Ground truth is MuJoCo running the scene generator's own contact model
(bench/pair_mujoco.py: pair friction the mean of the two sliding
coefficients, soft spring-damper contacts, spheres launched rolling); our
side is the engine with the same parameters. The slip share (0.45,
``FitConfig.contact_slip_removal``) was chosen on bench/bench_contact_friction.py's
cases (launch 1.5-2 m/s, offsets 0.1/0.2/0.3 m); these cases use other
speeds, offsets and frictions.
"""

from __future__ import annotations

import math

import pytest

from bench.bench_contact_friction import case_errors
from world.contacts import pair_friction, tangential_impulse
from world.identify.fit import FitConfig

SECONDS = 2.0
# (shapes, sliding frictions, launch speed m/s, offset m) not among the bench's cases.
CASES = [
    (("sphere", "sphere"), (0.35, 0.45), 1.5, 0.25),
    (("sphere", "cylinder"), (0.45, 0.06), 1.8, 0.15),
    (("cylinder", "sphere"), (0.1, 0.3), 2.2, 0.25),
]


@pytest.mark.parametrize("case", range(len(CASES)), ids=["sphere-sphere", "sphere-cylinder", "cylinder-sphere"])
def test_friction_between_bodies_brings_the_engine_closer_to_mujoco(case):
    shapes, frictions, speed, offset = CASES[case]
    models = {"frictionless": (False, 1.0, True), "friction": (True, FitConfig().contact_slip_removal, True)}
    errors = case_errors(shapes, frictions, speed, offset, SECONDS, models)
    assert errors, "the launch must produce a collision in MuJoCo"
    struck_before, _, worst_before = errors["frictionless"]
    struck_after, _, worst_after = errors["friction"]
    # Observed: the largest planar error over 2 s drops from 5-23 cm to 3-14 cm, the
    # struck body's direction from 1.3-3.1 to 0.5-1.1 degrees off MuJoCo's.
    assert worst_after < 0.7 * worst_before, f"max error {worst_after:.3f} m with friction vs {worst_before:.3f} m without"
    assert worst_after < 0.16
    assert abs(struck_after) < abs(struck_before)
    assert abs(struck_after) < 1.5


def _impulse(slip_speed, friction, removal=1.0, vertical_slip=0.0, vertical_compliance=0.0):
    """Two equal discs (1 kg, I = 0.02 kg m^2, levers -0.2 / 0.2 m) touching along n = (1, 0),
    sliding past each other at ``slip_speed`` along t = (0, 1), normal impulse 1 N s."""
    return tangential_impulse((1.0, 0.0), (0.0, slip_speed), (0.0, 0.0), (-0.2, 0.2), (1.0, 1.0), (0.02, 0.02),
                              1.0, friction, removal, vertical_slip, vertical_compliance)


def _slip_after(slip_speed, result):
    # u changes by J k, k = 1/m_i + 1/m_j + l_i^2/I_i + l_j^2/I_j = 2 + 2 * 0.04 / 0.02 = 6 per N s.
    return slip_speed + 6.0 * result.impulse


def test_sticking_stops_the_slip_and_never_reverses_it():
    result = _impulse(0.5, friction=10.0)
    assert result.sticking and _slip_after(0.5, result) == pytest.approx(0.0, abs=1e-12)
    # The spins it gives: the moment l * J about each centre over I.
    assert result.yaw_rate_change_i == pytest.approx(-0.2 * result.impulse / 0.02)
    assert result.yaw_rate_change_j == pytest.approx(-0.2 * result.impulse / 0.02)
    half = _impulse(0.5, friction=10.0, removal=0.45)
    assert _slip_after(0.5, half) == pytest.approx(0.55 * 0.5)


def test_coulomb_limits_the_impulse_in_the_tangent_plane():
    result = _impulse(3.0, friction=0.1)
    assert not result.sticking
    assert result.impulse == pytest.approx(-0.1)  # mu * normal impulse, against the slip
    assert 0.0 < _slip_after(3.0, result) < 3.0  # slows, does not reverse
    both = _impulse(3.0, friction=0.1, vertical_slip=-2.0, vertical_compliance=5.0)
    assert math.hypot(both.impulse, both.vertical) == pytest.approx(0.1)
    assert both.vertical > 0.0  # against the vertical slip


def test_pair_friction_is_the_mean_and_absent_means_frictionless():
    assert pair_friction(0.4, 0.1) == pytest.approx(0.25)
    assert pair_friction(None, None) == 0.0
    assert pair_friction(0.4, None) == pytest.approx(0.2)
