"""Footprint gaps: exact cases, symmetry, and agreement with dense boundary sampling."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from world.contacts import footprint_distance
from world.footprint import footprint_gap
from world.rollout import footprint_of
from world.types import Body, BodyState, Shape

SPHERE = Shape("sphere", radius=0.2)
CYLINDER = Shape("cylinder", radius=0.3, half_height=0.2)
CUBE = Shape("cube", half_extent=0.2)
SHAPES = {"sphere": SPHERE, "cylinder": CYLINDER, "cube": CUBE}


def gap(a, pa, ya, b, pb, yb) -> float:
    return float(footprint_gap(a, np.array([pa]), np.array([ya]), b, np.array([pb]), np.array([yb]))[0])


@pytest.mark.parametrize(
    "a, pa, ya, b, pb, yb, expected",
    [
        (SPHERE, (0, 0, 0.2), 0, SPHERE, (1, 0, 0.2), 0, 0.6),
        (SPHERE, (0, 0, 0.2), 0, CYLINDER, (0.5, 0, 0.2), 0, 0.0),
        (CUBE, (0, 0, 0.2), 0, CUBE, (1, 0, 0.2), 0, 0.6),
        (CUBE, (0, 0, 0.2), 0, CUBE, (0.3, 0, 0.2), 0, -0.1),
        (CUBE, (0, 0, 0.2), math.pi / 4, CUBE, (1, 0, 0.2), 0, 0.8 - 0.2 * math.sqrt(2)),
        (CUBE, (0, 0, 0.2), 0, SPHERE, (0, 0.7, 0.2), 0, 0.3),
        (SPHERE, (1, 1, 0.2), 0, CUBE, (0, 0, 0.2), 0, math.hypot(0.8, 0.8) - 0.2),
        # Vertical separation: a sphere 1 m above another is not touching although footprints coincide.
        (SPHERE, (0, 0, 0.2), 0, SPHERE, (0, 0, 1.2), 0, 0.6),
    ],
)
def test_exact_gaps(a, pa, ya, b, pb, yb, expected):
    assert gap(a, pa, ya, b, pb, yb) == pytest.approx(expected, abs=1e-9)


def _outline(shape: Shape, center, yaw, n=720) -> np.ndarray:
    if shape.kind == "cube":
        h = shape.half_extent
        t = np.linspace(-h, h, n // 4, endpoint=False)
        local = np.concatenate([np.stack([t, np.full_like(t, -h)], 1), np.stack([np.full_like(t, h), t], 1),
                                np.stack([-t, np.full_like(t, h)], 1), np.stack([np.full_like(t, -h), -t], 1)])
        c, s = math.cos(yaw), math.sin(yaw)
        return local @ np.array([[c, s], [-s, c]]) + np.asarray(center)
    angle = np.linspace(0, 2 * math.pi, n, endpoint=False)
    return np.asarray(center) + shape.radius * np.stack([np.cos(angle), np.sin(angle)], 1)


coordinate = st.floats(-2, 2, allow_nan=False)
yaw_angle = st.floats(-math.pi, math.pi, allow_nan=False)


@settings(max_examples=150, deadline=None)
@given(kind_a=st.sampled_from(sorted(SHAPES)), kind_b=st.sampled_from(sorted(SHAPES)),
       xa=coordinate, ya_=coordinate, xb=coordinate, yb_=coordinate, yaw_a=yaw_angle, yaw_b=yaw_angle)
def test_separated_gap_matches_boundary_sampling(kind_a, kind_b, xa, ya_, xb, yb_, yaw_a, yaw_b):
    a, b = SHAPES[kind_a], SHAPES[kind_b]
    value = gap(a, (xa, ya_, 0.2), yaw_a, b, (xb, yb_, 0.2), yaw_b)
    if value <= 0.01:
        return  # overlap depth is checked by the exact table; sampling only measures separated shapes
    sampled = np.min(np.linalg.norm(
        _outline(a, (xa, ya_), yaw_a)[:, None] - _outline(b, (xb, yb_), yaw_b)[None], axis=-1))
    assert value == pytest.approx(sampled, abs=2e-3)


@settings(max_examples=100, deadline=None)
@given(kind_a=st.sampled_from(sorted(SHAPES)), kind_b=st.sampled_from(sorted(SHAPES)),
       xa=coordinate, ya_=coordinate, xb=coordinate, yb_=coordinate, yaw_a=yaw_angle, yaw_b=yaw_angle,
       shift=st.tuples(coordinate, coordinate))
def test_gap_is_symmetric_and_translation_invariant(kind_a, kind_b, xa, ya_, xb, yb_, yaw_a, yaw_b, shift):
    a, b = SHAPES[kind_a], SHAPES[kind_b]
    forward = gap(a, (xa, ya_, 0.2), yaw_a, b, (xb, yb_, 0.2), yaw_b)
    backward = gap(b, (xb, yb_, 0.2), yaw_b, a, (xa, ya_, 0.2), yaw_a)
    moved = gap(a, (xa + shift[0], ya_ + shift[1], 0.2), yaw_a, b, (xb + shift[0], yb_ + shift[1], 0.2), yaw_b)
    assert forward == pytest.approx(backward, abs=1e-9)
    assert forward == pytest.approx(moved, abs=1e-9)


def test_vectorised_over_frames_matches_single_frames():
    rng = np.random.default_rng(3)
    pa, pb = rng.uniform(-1, 1, (50, 3)), rng.uniform(-1, 1, (50, 3))
    pa[:, 2] = pb[:, 2] = 0.2
    ya, yb = rng.uniform(-3, 3, 50), rng.uniform(-3, 3, 50)
    batch = footprint_gap(CUBE, pa, ya, SPHERE, pb, yb)
    single = [gap(CUBE, pa[i], ya[i], SPHERE, pb[i], yb[i]) for i in range(50)]
    np.testing.assert_allclose(batch, single, atol=1e-12)


def _footprint(shape: Shape):
    return footprint_of(Body(0, shape, BodyState((0.0, 0.0, shape.rest_height), (0.0, 0.0, 0.0))))


@settings(max_examples=300, deadline=None)
@given(
    st.sampled_from(sorted(SHAPES)), st.sampled_from(sorted(SHAPES)),
    st.floats(-1.0, 1.0), st.floats(-1.0, 1.0), st.floats(-math.pi, math.pi), st.floats(-math.pi, math.pi),
)
def test_the_frame_form_agrees_with_the_engines_exact_distance(name_a, name_b, dx, dy, yaw_a, yaw_b):
    """One geometry, two forms: the vectorised gap equals world.contacts' exact distance when apart, and both say overlap together."""
    a, b = SHAPES[name_a], SHAPES[name_b]
    pa, pb = (0.0, 0.0, a.rest_height), (dx, dy, a.rest_height)  # same height: only the footprints decide
    frame_gap = gap(a, pa, yaw_a, b, pb, yaw_b)
    exact, _, _ = footprint_distance(_footprint(a), 0.0, 0.0, yaw_a, _footprint(b), dx, dy, yaw_b)
    if exact > 1e-9:
        assert frame_gap == pytest.approx(exact, abs=1e-9)
    else:
        assert frame_gap <= 1e-9
