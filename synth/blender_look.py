"""The Blender look family: how a scene looks when synth.blender renders it with Cycles.

Its own family, unlike synth.looks (MuJoCo's rasteriser) and synth.povray_look
(POV-Ray): physically based Principled BSDF surfaces (metal = metallic 1 with
low roughness, rubber = metallic 0 with high roughness), a key light that is
either a sun (angular diameter from a fraction of a degree, hard shadows, to
over ten degrees, soft) or a square area light (soft shadows, size and
distance drawn), 0-2 fill lights, light of varied direction, colour
temperature and intensity, a world background that lights the scene too, and
a floor that is the real CLEVRER floor image, a plain colour, a noise texture
or a checker. Paint shades are drawn in hue/saturation/value around
BLENDER_PAINT_HSV (our own numbers, not POV-Ray's or CLEVR's palette).

Drawn once per scene from its own stream ``SeedSequence([seed, index,
BLENDER_LOOK_STREAM])``; camera, objects, object count and h264 quality stay
those of the scene's synth.looks family (``--looks``).

Colours here are sRGB 0..1 (synth.blender linearises them for Cycles) except
light colours, which are linear tints with mean 1; sun strength in W/m^2
(Blender's irradiance unit), area-light strength as the irradiance it gives at
the look-at point; lengths in metres in the world frame (z up); angles in degrees.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from synth.looks import check_rgb, jittered_paint, rounded, uniform_in
from world.types import COLORS

BLENDER_LOOK_STREAM = 4  # [seed, index] scene, [.., 1] questions, [.., 2, family] synth.looks, [.., 3] POV-Ray, [.., 4] this

BLENDER_FLOORS = ("clevrer", "plain", "noise", "checker")
LIGHT_KINDS = ("sun", "area")

BLENDER_PAINT_HSV: dict[str, tuple[float, float, float]] = {
    "gray": (0.0, 0.0, 0.45),
    "red": (358.0, 0.80, 0.68),
    "blue": (222.0, 0.80, 0.80),
    "green": (118.0, 0.75, 0.48),
    "brown": (25.0, 0.70, 0.50),
    "yellow": (52.0, 0.82, 0.92),
    "cyan": (184.0, 0.80, 0.78),
    "purple": (278.0, 0.72, 0.70),
}

# Ranges drawn uniformly per scene.
METAL_ROUGHNESS = (0.08, 0.3)  # Principled BSDF roughness with metallic 1
RUBBER_ROUGHNESS = (0.55, 0.9)  # with metallic 0
RUBBER_SPECULAR = (0.2, 0.5)  # Principled "Specular IOR Level" of rubber (0.5 = plastic-like)
LIGHT_COUNT = (1, 3)  # inclusive: the key light and up to two fills
KEY_SUN_SHARE = 0.5  # share of scenes whose key light is a sun (else an area light)
KEY_IRRADIANCE = (1.5, 3.2)  # W/m^2 at the look-at point (sun strength)
FILL_IRRADIANCE = (0.2, 0.8)
SUN_ANGLE_DEG = (0.3, 15.0)  # angular diameter: hard (small) to soft (large) shadows
AREA_SIZE = (0.5, 3.0)  # m, side of a square area light
LIGHT_DISTANCE = (5.0, 12.0)  # m from the look-at point (area lights)
LIGHT_ELEVATION_DEG = (30.0, 80.0)
BACKGROUND_STRENGTH = (0.1, 0.4)  # world background light


@dataclass(frozen=True)
class BlenderFloor:
    """Floor: ``kind`` in BLENDER_FLOORS; ``rgb`` and ``rgb2`` sRGB 0..1 (plain uses
    ``rgb``; noise and checker mix both; the CLEVRER image is tinted by ``rgb`` / its max);
    ``scale`` m (CLEVRER image tile, checker square, noise feature size); ``offset`` (2,) m
    shift of the pattern; ``roughness`` of its Principled BSDF."""

    kind: str
    rgb: tuple[float, float, float]
    rgb2: tuple[float, float, float]
    scale: float
    offset: tuple[float, float]
    roughness: float

    def __post_init__(self):
        if self.kind not in BLENDER_FLOORS:
            raise ValueError(f"kind: expected one of {BLENDER_FLOORS}, got {self.kind!r}")
        check_rgb("rgb", self.rgb)
        check_rgb("rgb2", self.rgb2)
        if not self.scale > 0:
            raise ValueError(f"scale: expected > 0 m, got {self.scale!r}")
        if not 0.0 <= self.roughness <= 1.0:
            raise ValueError(f"roughness: expected a value in [0, 1], got {self.roughness!r}")


@dataclass(frozen=True)
class BlenderLight:
    """One light. ``kind`` "sun": parallel light from ``direction`` (3,) (unit, towards the
    light), ``size`` its angular diameter in radians. ``kind`` "area": a square of side
    ``size`` m at ``distance`` m from the look-at point along ``direction``, facing it.
    ``irradiance`` W/m^2 at the look-at point; ``tint`` (3,) linear colour, mean 1."""

    kind: str
    direction: tuple[float, float, float]
    irradiance: float
    tint: tuple[float, float, float]
    size: float
    distance: float

    def __post_init__(self):
        if self.kind not in LIGHT_KINDS:
            raise ValueError(f"kind: expected one of {LIGHT_KINDS}, got {self.kind!r}")
        if len(self.direction) != 3 or not math.isclose(float(np.linalg.norm(self.direction)), 1.0, abs_tol=1e-6) \
                or self.direction[2] <= 0:
            raise ValueError(f"direction: expected a unit vector pointing up, got {self.direction!r}")
        if not self.irradiance > 0:
            raise ValueError(f"irradiance: expected > 0, got {self.irradiance!r}")
        if len(self.tint) != 3 or min(self.tint) <= 0:
            raise ValueError(f"tint: expected 3 positive values, got {self.tint!r}")
        if not self.size > 0:
            raise ValueError(f"size: expected > 0, got {self.size!r}")
        if self.kind == "area" and not self.distance > 0:
            raise ValueError(f"distance: an area light needs a distance > 0 m, got {self.distance!r}")


@dataclass(frozen=True)
class BlenderLook:
    """Everything Cycles draws besides geometry: floor, lights (key first), world
    background (sRGB colour and strength), the two materials' roughness and
    rubber's specular level, and the paint (sRGB 0..1) of every colour name of
    world.types.COLORS, in that order."""

    floor: BlenderFloor
    lights: tuple[BlenderLight, ...]
    background_rgb: tuple[float, float, float]
    background_strength: float
    metal_roughness: float
    rubber_roughness: float
    rubber_specular: float
    paints: tuple[tuple[float, float, float], ...]

    def __post_init__(self):
        if not LIGHT_COUNT[0] <= len(self.lights) <= LIGHT_COUNT[1]:
            raise ValueError(f"lights: expected {LIGHT_COUNT[0]}-{LIGHT_COUNT[1]}, got {len(self.lights)}")
        check_rgb("background_rgb", self.background_rgb)
        if self.background_strength < 0:
            raise ValueError(f"background_strength: expected >= 0, got {self.background_strength!r}")
        if len(self.paints) != len(COLORS):
            raise ValueError(f"paints: expected {len(COLORS)} colours, got {len(self.paints)}")
        for paint in self.paints:
            check_rgb("paints", paint)
        if not 0.0 < self.metal_roughness < self.rubber_roughness <= 1.0:
            raise ValueError("roughness: expected 0 < metal < rubber <= 1")
        if not 0.0 <= self.rubber_specular <= 1.0:
            raise ValueError(f"rubber_specular: expected a value in [0, 1], got {self.rubber_specular!r}")

    def paint(self, color: str) -> tuple[float, float, float]:
        """sRGB 0..1 paint of colour name ``color``."""
        return self.paints[COLORS.index(color)]


def blender_look_seed_sequence(seed: int, index: int) -> np.random.SeedSequence:
    return np.random.SeedSequence([seed, index, BLENDER_LOOK_STREAM])


def _floor(rng: np.random.Generator) -> BlenderFloor:
    kind = BLENDER_FLOORS[int(rng.integers(len(BLENDER_FLOORS)))]
    value = uniform_in(rng, (0.3, 0.8))
    tint = rng.uniform(-0.07, 0.07, 3)
    rgb = tuple(float(np.clip(value + t, 0.0, 1.0)) for t in tint)
    contrast = uniform_in(rng, (0.7, 0.9))
    scale = {"clevrer": (5.0, 11.0), "plain": (1.0, 1.0), "noise": (0.1, 0.6), "checker": (0.3, 1.0)}[kind]
    return BlenderFloor(kind=kind, rgb=rgb, rgb2=tuple(float(c * contrast) for c in rgb), scale=uniform_in(rng, scale),
                        offset=(uniform_in(rng, (-3.0, 3.0)), uniform_in(rng, (-3.0, 3.0))),
                        roughness=uniform_in(rng, (0.4, 0.95)))


def _light(rng: np.random.Generator, kind: str, irradiance: float) -> BlenderLight:
    azimuth, elevation = math.radians(rng.uniform(0.0, 360.0)), math.radians(uniform_in(rng, LIGHT_ELEVATION_DEG))
    direction = (math.cos(elevation) * math.cos(azimuth), math.cos(elevation) * math.sin(azimuth), math.sin(elevation))
    warmth = uniform_in(rng, (-1.0, 1.0))  # colour temperature, warm (+) to cool (-)
    tint = np.array([1.0 + 0.15 * warmth, 1.0, 1.0 - 0.18 * warmth]) * rng.uniform(0.95, 1.05, 3)
    size = math.radians(uniform_in(rng, SUN_ANGLE_DEG)) if kind == "sun" else uniform_in(rng, AREA_SIZE)
    distance = uniform_in(rng, LIGHT_DISTANCE) if kind == "area" else 0.0
    return BlenderLight(kind=kind, direction=direction, irradiance=irradiance,
                        tint=tuple(float(v) for v in tint / tint.mean()), size=size, distance=distance)


def sample_blender_look(rng: np.random.Generator) -> BlenderLook:
    """Draw a Blender look (lights are placed around the camera's look-at point by synth.blender)."""
    floor = _floor(rng)
    count = int(rng.integers(LIGHT_COUNT[0], LIGHT_COUNT[1] + 1))
    key_kind = "sun" if rng.uniform() < KEY_SUN_SHARE else "area"
    lights = [_light(rng, key_kind, uniform_in(rng, KEY_IRRADIANCE))]
    lights += [_light(rng, LIGHT_KINDS[int(rng.integers(2))], uniform_in(rng, FILL_IRRADIANCE)) for _ in range(count - 1)]
    background_value = uniform_in(rng, (0.5, 1.0))
    background_rgb = tuple(float(np.clip(background_value * f, 0, 1)) for f in rng.uniform(0.85, 1.1, 3))
    metal_roughness = uniform_in(rng, METAL_ROUGHNESS)
    rubber_roughness = uniform_in(rng, RUBBER_ROUGHNESS)
    paints = tuple(jittered_paint(rng, BLENDER_PAINT_HSV[c]) for c in COLORS)
    return BlenderLook(floor=floor, lights=tuple(lights), background_rgb=background_rgb,
                       background_strength=uniform_in(rng, BACKGROUND_STRENGTH), metal_roughness=metal_roughness,
                       rubber_roughness=rubber_roughness, rubber_specular=uniform_in(rng, RUBBER_SPECULAR), paints=paints)


def blender_look_document(look: BlenderLook) -> dict:
    """The look's parameters as JSON (ground_truth ``renderer.look``), rounded."""
    document = rounded(asdict(look))
    document["paints"] = {c: p for c, p in zip(COLORS, document["paints"])}
    return document
