"""Closed-form flows: exact Coulomb stop, no reversal, yaw decay, ballistic flight."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tests.world.scenes import CUBE, CYLINDER, SPHERE, body, world_of
from world.flows import FLIGHT, REST, SLIDE, start_segment
from world.rollout import simulate
from world.types import Body, BodyState

G = 9.81


@pytest.mark.parametrize("speed, heading_deg, mu", [
    (1.0, 0.0, 0.3), (2.5, 37.0, 0.5), (0.4, 200.0, 0.05), (3.0, -90.0, 0.9), (1.7, 123.0, 0.2),
])
def test_stop_time_and_position_match_the_formula(speed, heading_deg, mu):
    heading = math.radians(heading_deg)
    v = (speed * math.cos(heading), speed * math.sin(heading))
    world = world_of(body(0, (0.3, -0.2), v, friction=mu), fps=25.0)
    rollout = simulate(world, horizon_frames=200)
    stops = [e for e in rollout.events if e.kind == "stop"]
    assert len(stops) == 1
    expected_time = speed / (mu * G)
    expected_distance = speed * speed / (2 * mu * G)
    assert stops[0].time == pytest.approx(expected_time, rel=1e-12)
    expected_xy = (0.3 + expected_distance * math.cos(heading), -0.2 + expected_distance * math.sin(heading))
    assert stops[0].position[:2] == pytest.approx(expected_xy, abs=1e-12)
    # Every frame after the stop holds the stop position, with zero velocity.
    after = rollout.times > expected_time
    assert np.allclose(rollout.positions[after, 0, :2], expected_xy, atol=1e-12)
    assert np.all(rollout.velocities[after, 0] == 0.0)
    assert stops[0].frame == int(math.floor(expected_time * 25.0 + 0.5))


@pytest.mark.parametrize("speed, mu", [(2.0, 0.3), (0.8, 0.1)])
def test_sliding_never_reverses_and_follows_the_quadratic(speed, mu):
    world = world_of(body(0, (0.0, 0.0), (speed, 0.0), friction=mu), fps=200.0)
    rollout = simulate(world, horizon_frames=400)
    vx = rollout.velocities[:, 0, 0]
    assert np.all(vx >= 0.0)
    assert np.all(np.diff(rollout.positions[:, 0, 0]) >= 0.0)
    t = rollout.times
    tau = np.minimum(t, speed / (mu * G))
    assert np.allclose(rollout.positions[:, 0, 0], speed * tau - 0.5 * mu * G * tau ** 2, atol=1e-12)


@pytest.mark.parametrize("fps_a, fps_b", [(25.0, 1000.0), (25.0, 60.0)])
def test_sampling_rate_does_not_change_events(fps_a, fps_b):
    bodies = (body(0, (-1.0, 0.05), (3.0, 0.0), friction=0.2), body(1, (0.0, 0.0), friction=0.3),
              body(2, (0.8, -0.3), (0.0, 1.0), CUBE, friction=0.25), body(3, (-0.5, 1.0), (0.5, -2.0), SPHERE))
    duration = 4.0
    runs = []
    for fps in (fps_a, fps_b):
        rollout = simulate(world_of(*bodies, fps=fps), horizon_frames=int(duration * fps) + 1)
        runs.append([(e.kind, e.bodies, e.time) for e in rollout.events if e.kind in ("collision", "stop")])
    assert runs[0] == runs[1]
    assert any(kind == "collision" for kind, _, _ in runs[0])


def test_yaw_rate_decays_to_zero_at_the_common_stop_of_slide_and_spin():
    speed, mu, yaw_rate = 2.0, 0.4, 3.0
    world = world_of(body(0, (0, 0), (speed, 0.0), CUBE, yaw=0.1, yaw_rate=yaw_rate, friction=mu), fps=500.0)
    rollout = simulate(world, horizon_frames=600)
    # T = (v^2 + (I/m) w^2) / (mu g sqrt(v^2 + (w rho)^2)), written out here from the law.
    k, rho = CUBE.yaw_inertia_per_mass, CUBE.footprint_mean_radius
    t_stop = (speed**2 + k * yaw_rate**2) / (mu * G * math.hypot(speed, yaw_rate * rho))
    assert t_stop > speed / (mu * G)  # the spin lengthens the slide
    expected_final = 0.1 + 0.5 * yaw_rate * t_stop  # linear decay of the rate: area of a triangle
    assert rollout.yaw[-1, 0] == pytest.approx(expected_final, abs=1e-12)
    assert rollout.positions[-1, 0, 0] == pytest.approx(0.5 * speed * t_stop, abs=1e-12)
    assert np.all(np.diff(rollout.yaw[:, 0]) >= 0.0)
    stops = [e.time for e in rollout.events if e.kind == "stop"]
    assert stops == [pytest.approx(t_stop, abs=1e-12)]


def test_a_cube_spinning_in_place_stops_at_the_floor_torque_without_a_stop_event():
    mu, yaw_rate = 0.4, 5.0
    world = world_of(body(0, (0, 0), (0.0, 0.0), CUBE, yaw_rate=yaw_rate, friction=mu), fps=500.0)
    rollout = simulate(world, horizon_frames=600)
    # Torque mu m g rho (rho = 0.765 h, the square's mean distance from its centre) on I = 2/3 m h^2.
    h = CUBE.half_extent
    rho = h * (math.sqrt(2.0) + math.log(1.0 + math.sqrt(2.0))) / 3.0
    t_stop = yaw_rate / (mu * G * rho / (2.0 / 3.0 * h * h))
    assert rollout.yaw[-1, 0] == pytest.approx(0.5 * yaw_rate * t_stop, abs=1e-12)
    assert np.all(rollout.positions[:, 0, :2] == 0.0)
    assert not any(e.kind == "stop" for e in rollout.events)


@pytest.mark.parametrize("height, vz", [(0.5, 0.0), (0.2, 1.5)])
def test_flight_is_ballistic_and_lands_at_the_exact_time(height, vz):
    segment = start_segment(0.0, (0.0, 0.0, CYLINDER.rest_height + height), (1.0, 0.0, vz), 0.0, 0.0,
                            CYLINDER.rest_height, 0.3, G)
    assert segment.mode == FLIGHT
    t_land = (vz + math.sqrt(vz * vz + 2 * G * height)) / G
    assert segment.end == pytest.approx(t_land, rel=1e-12)
    position, velocity, _, _ = segment.state_at(t_land)
    assert position[2] == pytest.approx(CYLINDER.rest_height, abs=1e-12)
    assert position[0] == pytest.approx(t_land, rel=1e-12)  # no friction in flight
    start = BodyState((0.0, 0.0, CYLINDER.rest_height + height), (1.0, 0.0, vz))
    rollout = simulate(world_of(Body(0, CYLINDER, start, friction=0.3), fps=100.0), horizon_frames=200)
    # After landing it slides with Coulomb friction and stops at x = t_land + 1 / (2 mu g).
    assert rollout.positions[-1, 0, 0] == pytest.approx(t_land + 1.0 / (2 * 0.3 * G), rel=1e-9)
    assert rollout.positions[-1, 0, 2] == pytest.approx(CYLINDER.rest_height)


def test_resting_body_has_a_rest_segment():
    assert start_segment(0.0, (0, 0, 0.2), (0, 0, 0), 0.0, 1.0, 0.2, 0.3, G).mode == REST
    assert start_segment(0.0, (0, 0, 0.2), (1, 0, 0), 0.0, 1.0, 0.2, 0.3, G).mode == SLIDE
