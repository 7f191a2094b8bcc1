"""The planar rigid-body impulse at the contact point (contacts.collision_impulse) and the contact patch.

Laws that hold for every impact (hypothesis): kinetic energy (translation plus
spin about z) never increases, linear momentum and angular momentum about any
point are conserved, and the contact points do not approach after the impact.
"""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from world.contacts import (CIRCLE, PATCH_DEPTH, SQUARE, Footprint, collision_impulse, contact_normal_speed,
                            contact_patch_centre, footprint_distance)

finite = st.floats(-3.0, 3.0)


@st.composite
def impacts(draw):
    angle = draw(st.floats(0.0, 2.0 * math.pi))
    normal = (math.cos(angle), math.sin(angle))
    centres = ((draw(finite), draw(finite)), (draw(finite), draw(finite)))
    point = (draw(finite), draw(finite))
    velocities = ((draw(finite), draw(finite)), (draw(finite), draw(finite)))
    yaw_rates = (draw(st.floats(-8.0, 8.0)), draw(st.floats(-8.0, 8.0)))
    masses = (draw(st.floats(0.1, 5.0)), draw(st.floats(0.1, 5.0)))
    inertias = (masses[0] * draw(st.floats(0.005, 0.1)), masses[1] * draw(st.floats(0.005, 0.1)))
    return dict(normal=normal, point=point, centres=centres, velocities=velocities, yaw_rates=yaw_rates,
                masses=masses, yaw_inertias=inertias, restitution=draw(st.floats(0.0, 1.0)),
                friction=draw(st.floats(0.0, 1.5)), slip_removal=draw(st.floats(0.0, 1.0)))


def _after(impact, response):
    (vi, vj), (wi, wj) = impact["velocities"], impact["yaw_rates"]
    dvi, dvj = response.velocity_change_i, response.velocity_change_j
    return (((vi[0] + dvi[0], vi[1] + dvi[1]), (vj[0] + dvj[0], vj[1] + dvj[1])),
            (wi + response.yaw_rate_change_i, wj + response.yaw_rate_change_j))


def _energy(impact, velocities, yaw_rates):
    return sum(0.5 * m * (v[0] ** 2 + v[1] ** 2) + 0.5 * inertia * w * w
               for m, inertia, v, w in zip(impact["masses"], impact["yaw_inertias"], velocities, yaw_rates))


def _momentum(impact, velocities):
    return tuple(sum(m * v[axis] for m, v in zip(impact["masses"], velocities)) for axis in (0, 1))


def _angular_momentum(impact, velocities, yaw_rates, about):
    """About z through ``about``: sum of m (c - about) x v + I w."""
    total = 0.0
    for m, inertia, c, v, w in zip(impact["masses"], impact["yaw_inertias"], impact["centres"], velocities, yaw_rates):
        total += m * ((c[0] - about[0]) * v[1] - (c[1] - about[1]) * v[0]) + inertia * w
    return total


@settings(max_examples=300, deadline=None)
@given(impacts(), st.tuples(finite, finite))
def test_an_impact_never_adds_energy_and_conserves_momenta(impact, about):
    response = collision_impulse(**impact)
    velocities, yaw_rates = _after(impact, response)
    before = _energy(impact, impact["velocities"], impact["yaw_rates"])
    assert _energy(impact, velocities, yaw_rates) <= before + 1e-9 * (1.0 + before)
    for got, want in zip(_momentum(impact, velocities), _momentum(impact, impact["velocities"])):
        assert got == pytest.approx(want, abs=1e-9)
    assert _angular_momentum(impact, velocities, yaw_rates, about) == pytest.approx(
        _angular_momentum(impact, impact["velocities"], impact["yaw_rates"], about), abs=1e-8)
    assert response.normal_impulse >= 0.0
    # The contact points leave each other (or slide along) after the impact.
    assert contact_normal_speed(impact["normal"], impact["point"], impact["centres"], velocities, yaw_rates) >= -1e-9


def test_restitution_holds_at_the_contact_point_and_an_off_centre_hit_spins():
    # Two unit squares' worth of inertia: i at the origin is hit on its left face 0.1 m above
    # its centre by j moving +x; n from j to i = (1, 0).
    inertia = 2.0 / 3.0 * 0.2**2
    response = collision_impulse((1.0, 0.0), (-0.2, 0.1), ((0.0, 0.0), (-0.4, 0.2)), ((0.0, 0.0), (2.0, 0.0)),
                                 (0.0, 0.0), (1.0, 1.0), (inertia, inertia), restitution=0.7)
    arm = 0.1  # |r x n| for both bodies: the point is 0.1 m off each centre line
    k = 2.0 + 2.0 * arm * arm / inertia
    assert response.normal_impulse == pytest.approx(1.7 * 2.0 / k, rel=1e-12)
    # i is pushed +x at a point above its centre: it turns clockwise.
    assert response.yaw_rate_change_i == pytest.approx(-arm * response.normal_impulse / inertia, rel=1e-12)
    # j is pushed back (-x) at a point below its centre: clockwise too.
    assert response.yaw_rate_change_j == pytest.approx(-arm * response.normal_impulse / inertia, rel=1e-12)
    velocities, yaw_rates = _after(dict(velocities=((0.0, 0.0), (2.0, 0.0)), yaw_rates=(0.0, 0.0)), response)
    speed_after = contact_normal_speed((1.0, 0.0), (-0.2, 0.1), ((0.0, 0.0), (-0.4, 0.2)), velocities, yaw_rates)
    assert speed_after == pytest.approx(0.7 * 2.0, rel=1e-12)


def test_circles_get_no_spin_from_the_normal_impulse():
    # The contact point of two circles is on the centre line: no arm.
    gap, normal, point = footprint_distance(Footprint(CIRCLE, 0.2), 0.4, 0.1, 0.0, Footprint(CIRCLE, 0.2), 0.0, 0.0, 0.0)
    response = collision_impulse(normal, point, ((0.4, 0.1), (0.0, 0.0)), ((0.0, 0.0), (1.0, 0.5)), (0.0, 0.0),
                                 (1.0, 1.0), (0.02, 0.02), restitution=0.8)
    assert response.normal_impulse > 0.0
    assert response.yaw_rate_change_i == pytest.approx(0.0, abs=1e-12)
    assert response.yaw_rate_change_j == pytest.approx(0.0, abs=1e-12)


SQUARE_02 = Footprint(SQUARE, 0.2)


def _touching_patch(yaw_j: float, offset: float):
    """Square i (yaw 0) at (0, 0); square j at yaw ``yaw_j`` to its left, ``offset`` m lower, just touching."""
    for step in range(2000):  # slide j right until the footprints touch
        x = -0.9 + step * 5e-4
        gap, normal, point = footprint_distance(SQUARE_02, 0.0, 0.0, 0.0, SQUARE_02, x, -offset, yaw_j)
        if gap <= 5e-4:
            return contact_patch_centre(SQUARE_02, 0.0, 0.0, 0.0, SQUARE_02, x, -offset, yaw_j, normal, point)
    raise AssertionError("never touched")


def test_two_flat_faces_push_at_the_middle_of_their_overlap():
    centre = _touching_patch(0.0, 0.1)
    # i spans y in [-0.2, 0.2], j in [-0.3, 0.1]: the overlap [-0.2, 0.1] has its middle at -0.05.
    assert centre[1] == pytest.approx(-0.05, abs=1e-9)
    assert centre[0] == pytest.approx(-0.2, abs=1e-3)


def test_a_corner_pushes_at_the_corner_and_a_nearly_flat_face_moves_the_patch_smoothly():
    corner = _touching_patch(math.pi / 4, 0.1)
    # j's corner at its centre's height reaches i's left face: the patch is that corner.
    assert corner[1] == pytest.approx(-0.1, abs=1e-3)
    flat = _touching_patch(0.0, 0.1)[1]
    tilts = [_touching_patch(angle, 0.1)[1] for angle in (1e-4, 1e-3, 1e-2)]
    # Tilting j's face by a little moves the patch from the overlap's middle towards j's leading corner,
    # more for more tilt; a tilt of PATCH_DEPTH / (0.4 m) or less keeps most of the face in contact.
    assert abs(tilts[0] - flat) < 0.02
    assert abs(tilts[0] - flat) <= abs(tilts[1] - flat) <= abs(tilts[2] - flat)
    assert PATCH_DEPTH / 0.4 > 1e-3


def test_a_vanishing_mass_takes_no_impulse_and_no_division_by_zero():
    # A set_mass edit can make mass x inertia-per-mass underflow to 0 (the tool server's fuzz found it).
    tiny = 1e-320
    response = collision_impulse((1.0, 0.0), (-0.2, 0.1), ((0.0, 0.0), (-0.4, 0.2)), ((0.0, 0.0), (2.0, 0.0)),
                                 (0.0, 0.0), (tiny, 1.0), (0.0, 0.0267), restitution=0.7)  # inertia underflowed
    values = [response.normal_impulse, response.yaw_rate_change_i, response.yaw_rate_change_j]
    assert all(math.isfinite(v) for v in values)
    assert abs(response.normal_impulse) < 1e-300
