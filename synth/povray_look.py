"""The POV-Ray look family: how a scene looks when synth.povray ray-traces it.

Its own family, deliberately unlike synth.looks (which drives MuJoCo's
rasteriser): true reflections on metal (it mirrors the floor, the sky and the
other objects), area lights with soft shadows or point lights with hard ones,
1-3 lights of varied colour and intensity, a sky dome, an image-mapped floor
(the real CLEVRER floor) among plain and procedurally textured floors, and
CLEVRER-like paint shades drawn in hue/saturation/value around POVRAY_PAINT_HSV
(not synth.looks' channel-scaled CLEVR palette).

Drawn once per scene from its own stream ``SeedSequence([seed, index,
POVRAY_LOOK_STREAM])``; camera, objects, object count and h264 quality stay
those of the scene's synth.looks family (``--looks``).

Colours here are sRGB 0..1 (POV-Ray's ``srgb`` keyword linearises them);
lengths in metres in the world frame (z up); angles in degrees.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from synth.looks import check_rgb, jittered_paint, rounded, uniform_in
from world.types import COLORS

POVRAY_LOOK_STREAM = 3  # [seed, index] scene, [.., 1] questions, [.., 2, family] synth.looks, [.., 3] this look

POVRAY_FLOORS = ("clevrer", "plain", "noise", "checker")

# Paint of each colour name: (hue deg, saturation, value) centre, CLEVRER-like but
# our own numbers; per scene each is jittered by synth.looks.PAINT_JITTER.
POVRAY_PAINT_HSV: dict[str, tuple[float, float, float]] = {
    "gray": (0.0, 0.0, 0.40),
    "red": (2.0, 0.78, 0.70),
    "blue": (226.0, 0.78, 0.82),
    "green": (112.0, 0.78, 0.45),
    "brown": (27.0, 0.76, 0.52),
    "yellow": (54.0, 0.80, 0.95),
    "cyan": (181.0, 0.78, 0.80),
    "purple": (274.0, 0.75, 0.74),
}

# Ranges drawn uniformly per scene.
METAL_RANGES = {
    "reflection": (0.3, 0.8),  # share of the mirrored image (POV-Ray reflection, metallic)
    "body": (0.45, 0.8),  # body colour = paint x this (darkened)
    "diffuse": (0.3, 0.6),
    "specular": (0.5, 0.9),
    "roughness": (0.005, 0.03),
}
RUBBER_RANGES = {"diffuse": (0.75, 0.95), "specular": (0.02, 0.12), "roughness": (0.05, 0.2)}
AMBIENT_RANGE = (0.12, 0.3)  # finish ambient of every surface
LIGHT_COUNT = (1, 3)  # inclusive
KEY_INTENSITY = (0.8, 1.3)
EXTRA_INTENSITY = (0.15, 0.45)
LIGHT_ELEVATION_DEG = (30.0, 78.0)
LIGHT_DISTANCE = (7.0, 14.0)  # m from the camera's look-at point
AREA_LIGHT_SIZE = (0.6, 2.5)  # m, side of a square area light
AREA_LIGHT_SHARE = 0.6  # share of lights that are area lights (soft shadows)
AREA_LIGHT_SAMPLES = 3  # 3 x 3 shadow rays (adaptive 0: corners first, jittered): soft but affordable


@dataclass(frozen=True)
class PovFloor:
    """Floor: ``kind`` in POVRAY_FLOORS; ``rgb`` and ``rgb2`` sRGB 0..1 (plain uses
    ``rgb``; noise and checker mix both); ``scale`` m (image size of the CLEVRER
    floor, checker square, noise grain); ``offset`` (2,) m shift of the pattern;
    ``specular`` and ``reflection`` of its finish."""

    kind: str
    rgb: tuple[float, float, float]
    rgb2: tuple[float, float, float]
    scale: float
    offset: tuple[float, float]
    specular: float
    reflection: float

    def __post_init__(self):
        if self.kind not in POVRAY_FLOORS:
            raise ValueError(f"kind: expected one of {POVRAY_FLOORS}, got {self.kind!r}")
        check_rgb("rgb", self.rgb)
        check_rgb("rgb2", self.rgb2)
        if not self.scale > 0:
            raise ValueError(f"scale: expected > 0 m, got {self.scale!r}")
        if not (0.0 <= self.specular <= 1.0 and 0.0 <= self.reflection <= 1.0):
            raise ValueError("specular, reflection: expected values in [0, 1]")


@dataclass(frozen=True)
class PovLight:
    """One light at ``position`` (3,) m, colour ``rgb`` (linear, may exceed 1);
    ``area_size`` m > 0 makes it a square area light (soft shadows), 0 a point light (hard)."""

    position: tuple[float, float, float]
    rgb: tuple[float, float, float]
    area_size: float

    def __post_init__(self):
        if len(self.position) != 3 or self.position[2] <= 0:
            raise ValueError(f"position: expected (x, y, z) above the floor, got {self.position!r}")
        if len(self.rgb) != 3 or min(self.rgb) < 0:
            raise ValueError(f"rgb: expected 3 non-negative values, got {self.rgb!r}")
        if self.area_size < 0:
            raise ValueError(f"area_size: expected >= 0 m, got {self.area_size!r}")


@dataclass(frozen=True)
class PovFinish:
    """A POV-Ray finish: ``reflection`` 0 for rubber; ``body`` scales the paint."""

    diffuse: float
    specular: float
    roughness: float
    reflection: float
    body: float

    def __post_init__(self):
        for name in ("diffuse", "specular", "reflection", "body"):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise ValueError(f"{name}: expected a value in [0, 1], got {getattr(self, name)!r}")
        if not 0.0 < self.roughness <= 1.0:
            raise ValueError(f"roughness: expected (0, 1], got {self.roughness!r}")


@dataclass(frozen=True)
class PovLook:
    """Everything POV-Ray draws besides geometry: floor, lights, sky (horizon and
    zenith sRGB), ambient, the two materials' finishes and the paint (sRGB 0..1)
    of every colour name of world.types.COLORS, in that order."""

    floor: PovFloor
    lights: tuple[PovLight, ...]
    sky_horizon: tuple[float, float, float]
    sky_zenith: tuple[float, float, float]
    ambient: float
    metal: PovFinish
    rubber: PovFinish
    paints: tuple[tuple[float, float, float], ...]

    def __post_init__(self):
        if not LIGHT_COUNT[0] <= len(self.lights) <= LIGHT_COUNT[1]:
            raise ValueError(f"lights: expected {LIGHT_COUNT[0]}-{LIGHT_COUNT[1]}, got {len(self.lights)}")
        check_rgb("sky_horizon", self.sky_horizon)
        check_rgb("sky_zenith", self.sky_zenith)
        if len(self.paints) != len(COLORS):
            raise ValueError(f"paints: expected {len(COLORS)} colours, got {len(self.paints)}")
        for paint in self.paints:
            check_rgb("paints", paint)
        if self.metal.reflection <= 0 or self.rubber.reflection != 0:
            raise ValueError("metal must reflect (reflection > 0), rubber must not (reflection 0)")

    def paint(self, color: str) -> tuple[float, float, float]:
        """sRGB 0..1 paint of colour name ``color``."""
        return self.paints[COLORS.index(color)]


def povray_look_seed_sequence(seed: int, index: int) -> np.random.SeedSequence:
    return np.random.SeedSequence([seed, index, POVRAY_LOOK_STREAM])


def _floor(rng: np.random.Generator) -> PovFloor:
    kind = POVRAY_FLOORS[int(rng.integers(len(POVRAY_FLOORS)))]
    # A neutral-to-warm or cool grey, light or dark; the second tone close to it.
    value = uniform_in(rng, (0.35, 0.8))
    tint = rng.uniform(-0.06, 0.06, 3)
    rgb = tuple(float(np.clip(value + t, 0.0, 1.0)) for t in tint)
    contrast = uniform_in(rng, (0.75, 0.92))
    rgb2 = tuple(float(c * contrast) for c in rgb)
    scale = {"clevrer": (6.0, 12.0), "plain": (1.0, 1.0), "noise": (0.05, 0.4), "checker": (0.4, 1.2)}[kind]
    return PovFloor(
        kind=kind,
        rgb=rgb,
        rgb2=rgb2,
        scale=uniform_in(rng, scale),
        offset=(uniform_in(rng, (-3.0, 3.0)), uniform_in(rng, (-3.0, 3.0))),
        specular=uniform_in(rng, (0.0, 0.3)),
        reflection=uniform_in(rng, (0.0, 0.08)),
    )


def _light(rng: np.random.Generator, target: tuple[float, float, float], intensity: float) -> PovLight:
    azimuth, elevation = math.radians(rng.uniform(0.0, 360.0)), math.radians(uniform_in(rng, LIGHT_ELEVATION_DEG))
    distance = uniform_in(rng, LIGHT_DISTANCE)
    offset = distance * np.array([math.cos(elevation) * math.cos(azimuth), math.cos(elevation) * math.sin(azimuth), math.sin(elevation)])
    # Colour temperature from warm to cool, normalised to the intensity.
    warmth = uniform_in(rng, (-1.0, 1.0))
    tint = np.array([1.0 + 0.12 * warmth, 1.0, 1.0 - 0.15 * warmth]) * rng.uniform(0.95, 1.05, 3)
    area = uniform_in(rng, AREA_LIGHT_SIZE) if rng.uniform() < AREA_LIGHT_SHARE else 0.0
    return PovLight(
        position=tuple(float(v) for v in np.asarray(target) + offset),
        rgb=tuple(float(v) for v in intensity * tint / tint.mean()),
        area_size=area,
    )


def sample_povray_look(rng: np.random.Generator, target: tuple[float, float, float]) -> PovLook:
    """Draw a POV-Ray look; ``target`` (3,) m is the camera's look-at point (lights aim around it)."""
    floor = _floor(rng)
    count = int(rng.integers(LIGHT_COUNT[0], LIGHT_COUNT[1] + 1))
    lights = [_light(rng, target, uniform_in(rng, KEY_INTENSITY))]
    lights += [_light(rng, target, uniform_in(rng, EXTRA_INTENSITY)) for _ in range(count - 1)]
    zenith_value = uniform_in(rng, (0.3, 0.9))
    sky_zenith = tuple(float(np.clip(zenith_value * f, 0, 1)) for f in rng.uniform(0.8, 1.1, 3))
    sky_horizon = tuple(float(np.clip(uniform_in(rng, (0.6, 1.0)) * f, 0, 1)) for f in rng.uniform(0.9, 1.05, 3))
    metal = PovFinish(reflection=uniform_in(rng, METAL_RANGES["reflection"]), body=uniform_in(rng, METAL_RANGES["body"]),
                      diffuse=uniform_in(rng, METAL_RANGES["diffuse"]), specular=uniform_in(rng, METAL_RANGES["specular"]),
                      roughness=uniform_in(rng, METAL_RANGES["roughness"]))
    rubber = PovFinish(reflection=0.0, body=1.0, diffuse=uniform_in(rng, RUBBER_RANGES["diffuse"]),
                       specular=uniform_in(rng, RUBBER_RANGES["specular"]), roughness=uniform_in(rng, RUBBER_RANGES["roughness"]))
    paints = tuple(jittered_paint(rng, POVRAY_PAINT_HSV[c]) for c in COLORS)
    return PovLook(floor=floor, lights=tuple(lights), sky_horizon=sky_horizon, sky_zenith=sky_zenith,
                   ambient=uniform_in(rng, AMBIENT_RANGE), metal=metal, rubber=rubber, paints=paints)


def povray_look_document(look: PovLook) -> dict:
    """The look's parameters as JSON (ground_truth ``renderer.look``), rounded."""
    document = rounded(asdict(look))
    document["paints"] = {c: p for c, p in zip(COLORS, document["paints"])}
    return document
