"""Closed-form 3D motion laws and exact event roots (no MuJoCo): each law against its formula."""

from __future__ import annotations

import math

import numpy as np
import pytest

from world.scene3d.motion import (
    bounce_velocity, leave_face_time, plane_contact_time, position_at, quadratic_roots, sliding_acceleration, stop_time,
)
from world.scene3d.rollout import simulate3d
from world.scene3d.types import Body3D, Phase3D, State3D, StaticBox, World3D

G = 9.81
FLOOR = StaticBox(100, "floor", (0, 0, -0.5), (20, 20, 0.5))


def top_face(box: StaticBox):
    return max(box.faces(), key=lambda f: f.normal[2])


def test_quadratic_roots_match_the_formula():
    assert quadratic_roots(1.0, -3.0, 2.0) == pytest.approx([1.0, 2.0])
    assert quadratic_roots(0.0, 2.0, -4.0) == pytest.approx([2.0])
    assert quadratic_roots(1.0, 0.0, 1.0) == []


def test_drop_time_is_the_root_of_the_fall():
    p0, v0 = np.array([0.0, 0.0, 1.1]), np.zeros(3)
    tau = plane_contact_time(p0, v0, np.array([0, 0, -G]), top_face(FLOOR), 0.1, 5.0)
    assert tau == pytest.approx(math.sqrt(2 * 1.0 / G), rel=1e-12)


def test_contact_outside_the_face_is_no_contact():
    box = StaticBox(101, "platform", (0, 0, 0.2), (0.5, 0.5, 0.2))
    tau = plane_contact_time(np.array([2.0, 0, 1.0]), np.zeros(3), np.array([0, 0, -G]), top_face(box), 0.1, 5.0)
    assert tau is None


def test_leaving_a_platform_edge_at_the_exact_time():
    box = StaticBox(101, "platform", (0, 0, 0.2), (0.5, 0.5, 0.2))
    tau = leave_face_time(np.array([0.0, 0, 0.5]), np.array([2.0, 0, 0]), np.zeros(3), top_face(box), 5.0)
    assert tau == pytest.approx(0.25)


def test_sliding_on_an_incline_follows_g_sin_minus_mu_g_cos():
    theta, mu = math.radians(30), 0.2
    normal = np.array([math.sin(theta), 0, math.cos(theta)])
    down = np.array([math.cos(theta), 0, -math.sin(theta)])
    accel = sliding_acceleration(normal, 0.5 * down, mu, G)
    assert accel @ down == pytest.approx(G * (math.sin(theta) - mu * math.cos(theta)))
    assert accel @ normal == pytest.approx(0.0, abs=1e-12)
    # at rest and mu >= tan(theta): stays at rest
    assert np.allclose(sliding_acceleration(normal, np.zeros(3), 0.6, G), 0.0)


def test_stop_time_on_the_floor():
    accel = sliding_acceleration(np.array([0, 0, 1.0]), np.array([2.0, 0, 0]), 0.4, G)
    assert stop_time(np.array([2.0, 0, 0]), accel) == pytest.approx(2.0 / (0.4 * G))


def test_bounce_reverses_the_normal_part_and_caps_friction():
    v = np.array([1.0, 0.0, -2.0])
    out = bounce_velocity(v, np.array([0, 0, 1.0]), 0.5, 0.0, "sphere")
    assert out == pytest.approx([1.0, 0.0, 1.0])
    slowed = bounce_velocity(v, np.array([0, 0, 1.0]), 0.5, 0.1, "cube")
    assert slowed[0] == pytest.approx(1.0 - 0.1 * 1.5 * 2.0)
    rolling = bounce_velocity(v, np.array([0, 0, 1.0]), 0.5, 5.0, "sphere")
    assert rolling[0] == pytest.approx(5.0 / 7.0)


def test_rollout_bounce_heights_shrink_by_e_squared():
    e = 0.6
    ball = Body3D(0, "sphere", 0.1, restitution=e, role="agent")
    phase = Phase3D(0.0, (FLOOR,), ((0, State3D((0, 0, 1.1))),))
    rollout = simulate3d(World3D((ball,), (phase,)), phase, 1.5)
    impacts = [ev.time for ev in rollout.events if ev.kind == "surface"]
    t1 = math.sqrt(2 / G)
    assert impacts[0] == pytest.approx(t1)
    assert impacts[1] - impacts[0] == pytest.approx(2 * e * t1)  # flight time scales with rebound speed
    apex = rollout.state(0, impacts[0] + e * t1).position[2]
    assert apex - 0.1 == pytest.approx(e * e * 1.0)


def test_world_types_validate_themselves():
    with pytest.raises(ValueError, match="role"):
        StaticBox(1, "lava", (0, 0, 0), (1, 1, 1))
    with pytest.raises(ValueError, match="orientation"):
        StaticBox(1, "wall", (0, 0, 0), (1, 1, 1), (0, 0, 0, 2))
    with pytest.raises(ValueError, match="half_extents"):
        StaticBox(1, "wall", (0, 0, 0), (1, 0, 1))
    with pytest.raises(ValueError, match="restitution"):
        Body3D(0, "sphere", 0.1, restitution=1.5)
    phase = Phase3D(0.0, (FLOOR,), ((0, State3D((0, 0, 0.1))),))
    with pytest.raises(ValueError, match="patient_zone"):
        World3D((Body3D(0, "cube", 0.1),), (phase,), patient_zone=100)


def test_position_law_is_ballistic():
    p = position_at(np.zeros(3), np.array([1.0, 0, 2.0]), np.array([0, 0, -G]), np.array([0.5]))
    assert p[0] == pytest.approx([0.5, 0.0, 1.0 - 0.5 * G * 0.25])


def test_a_start_at_contact_moving_into_the_floor_neither_tunnels_nor_brakes():
    """A tracked frame of a sliding cube carries a downward jitter: it must stay on the floor at full speed;
    a ball caught at the floor mid-impact must rebound with its restitution."""
    cube = Body3D(0, "cube", 0.1, friction=0.3)
    ball = Body3D(1, "sphere", 0.1, restitution=0.5)
    phase = Phase3D(0.0, (FLOOR,), ((0, State3D((0.0, 0.0, 0.0998), (1.35, 0.0, -0.2))),
                                    (1, State3D((0.0, 3.0, 0.1), (0.0, 0.0, -2.0)))))
    rollout = simulate3d(World3D((cube, ball), (phase,)), phase, 0.3)
    slid = rollout.state(0, 0.3)
    assert slid.position[2] == pytest.approx(0.1, abs=1e-3)
    assert slid.position[0] == pytest.approx(1.35 * 0.3 - 0.5 * 0.3 * G * 0.3**2, abs=1e-3)  # Coulomb from full speed
    assert rollout.state(1, 0.05).velocity[2] == pytest.approx(1.0 - G * 0.05, abs=1e-6)
