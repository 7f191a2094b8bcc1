"""Appearance ("look") of a generated scene: floor, lights, shadows, camera, video quality.

Perception must not depend on one renderer's look, so the generator can vary
what real videos vary. Looks come in three families (``physmind synth --looks``):

* ``default``: the synth-1 look (grey flat floor, three fixed lights, camera
  about 45 degrees down 5.2-5.8 m away, fov 36, crf 18, 3-6 objects). It
  reproduces tests/data/synth exactly.
* ``tune``: looks to tune perception on.
* ``heldout``: looks to evaluate on, never used while tuning.

``tune`` and ``heldout`` are disjoint (and both disjoint from ``default``) in
floor (texture kind and colour range), light set-up (key-light direction and
intensity, colour tint) and camera (distance, tilt and field of view bands).
They are also disjoint in how the two materials render (MATERIAL_RANGES:
metal specular, shininess and how much darker its body colour is than the
paint; rubber specular and shininess), since other
renderers define "metal" and "rubber" their own way.
Shared by both: shadow style (hard, soft, none), h264 crf 18-30, 3-8 objects,
a share of objects placed partly out of view, camera azimuth jitter, and a
slight per-colour shade jitter of the paint (PALETTE_SHADE_JITTER).

Camera ranges span +-25 % around the default's centre (distance 5.5 m, tilt
45 deg, fov 36 deg), cut into four bands: ``tune`` takes bands 1 and 3,
``heldout`` bands 2 and 4, and the default's own range is cut out of both.
The camera height (distance x sin(tilt), 2.3-5.7 m) and the objects' size in
pixels (0.4 m x f / distance) follow from these.

A look is drawn once per scene from its own random stream
(``SeedSequence([seed, index, LOOK_STREAM, family code])``), so the scene's
re-draws for enough collisions keep the look. Units: metres, degrees, colours
linear 0..1 RGB as MuJoCo takes them.
"""

from __future__ import annotations

import colorsys
import math
from dataclasses import asdict, dataclass
from importlib import resources

import numpy as np

from world.types import CLEVR_PALETTE_RGB

LOOK_FAMILIES = ("default", "tune", "heldout")
_FAMILY_CODE = {"default": 0, "tune": 1, "heldout": 2}
LOOK_STREAM = 2  # third entry of the look's SeedSequence (the scene uses [seed, index], questions [seed, index, 1])

FLOOR_TEXTURES = ("flat", "checker", "speckle", "clevrer")
SHADOW_STYLES = ("hard", "soft", "none")
CLEVRER_FLOOR_FILE = "clevrer_floor.png"  # CLEVRER's own empty-floor render, shipped in synth/data

# Camera ranges: +-25 % around the default's centre, in four bands each.
CAMERA_CENTRE = {"distance": 5.5, "tilt_deg": 45.0, "fovy_deg": 36.0}
# The default look's camera ranges (synth.scene's sampler); no family may use them.
DEFAULT_CAMERA_RANGES = {"distance": (5.2, 5.8), "tilt_deg": (42.0, 48.0), "fovy_deg": (36.0, 36.0)}
CAMERA_YAW_RANGE_DEG = (-8.0, 8.0)  # azimuth jitter, shared by both families
TARGET_JITTER = 0.2  # m, look-at point jitter around synth.scene.CAMERA_TARGET


def _bands(name: str) -> list[tuple[float, float]]:
    """The four +-25 % bands of camera quantity ``name``, minus the default's range."""
    centre = CAMERA_CENTRE[name]
    edges = [centre * (1.0 + f) for f in (-0.25, -0.125, 0.0, 0.125, 0.25)]
    low, high = DEFAULT_CAMERA_RANGES[name]
    bands = []
    for a, b in zip(edges[:-1], edges[1:]):
        if b <= low or a >= high:
            bands.append((a, b))
        elif a < low:
            bands.append((a, low - 1e-6 if b > low else b))
        elif b > high:
            bands.append((high + 1e-6, b))
        # a band inside the default range vanishes
    return bands


def camera_bands(family: str, name: str) -> list[tuple[float, float]]:
    """Disjoint (low, high) ranges of camera quantity ``name`` used by ``family``."""
    bands = _bands(name)
    if family == "tune":
        return [bands[0], bands[2]]
    if family == "heldout":
        return [bands[1], bands[3]]
    raise ValueError(f"family: expected 'tune' or 'heldout', got {family!r}")


# Floor presets per family: texture kind and the range of its base colour
# (linear RGB, drawn on the segment from ``low`` to ``high``; a preset's second
# colour is the base scaled by ``contrast``). Value ranges are disjoint between families
# and from the default's 0.52 grey.
FLOOR_PRESETS: dict[str, tuple[dict, ...]] = {
    "tune": (
        {"texture": "flat", "low": (0.38, 0.38, 0.38), "high": (0.47, 0.47, 0.47), "contrast": 1.0},
        {"texture": "checker", "low": (0.55, 0.48, 0.38), "high": (0.62, 0.55, 0.45), "contrast": 0.9},
        {"texture": "speckle", "low": (0.40, 0.46, 0.36), "high": (0.47, 0.52, 0.42), "contrast": 0.8},
    ),
    "heldout": (
        {"texture": "clevrer", "low": (1.0, 1.0, 1.0), "high": (1.0, 1.0, 1.0), "contrast": 1.0},
        {"texture": "flat", "low": (0.58, 0.58, 0.58), "high": (0.70, 0.70, 0.70), "contrast": 1.0},
        {"texture": "speckle", "low": (0.46, 0.52, 0.62), "high": (0.52, 0.58, 0.70), "contrast": 0.85},
    ),
}

# Key-light set-ups per family: direction the light comes from (azimuth from
# +x, counter-clockwise; elevation above the floor), diffuse intensity, tint.
# The default key light comes from azimuth 232 deg, elevation 60 deg, 0.55 white.
LIGHT_RANGES: dict[str, dict[str, tuple]] = {
    "tune": {
        "azimuth_deg": (150.0, 215.0),
        "elevation_deg": (50.0, 75.0),
        "intensity": (0.40, 0.52),
        "tint_low": (1.0, 0.90, 0.75),
        "tint_high": (1.0, 0.97, 0.90),
        "ambient": (0.26, 0.34),
    },
    "heldout": {
        "azimuth_deg": (0.0, 120.0),
        "elevation_deg": (35.0, 50.0),
        "intensity": (0.55, 0.70),
        "tint_low": (0.80, 0.90, 1.0),
        "tint_high": (0.92, 0.97, 1.0),
        "ambient": (0.20, 0.26),
    },
}
# How metal and rubber render, per family (ranges disjoint between families).
# The default look renders metal with specular 1, shininess 0.7 and its body
# at 0.62 x the paint; rubber specular and shininess
# 0.05 (synth.mjcf). ``metal_body``: metal body colour = paint x this factor.
# MuJoCo's material ``reflectance`` is not varied: with MuJoCo 4.0.0 it changed
# no pixel of a metal cube, sphere or cylinder (reflections render on planes).
MATERIAL_RANGES: dict[str, dict[str, tuple[float, float]]] = {
    "tune": {
        "metal_specular": (0.50, 0.80),
        "metal_shininess": (0.30, 0.60),
        "metal_body": (0.50, 0.80),
        "rubber_specular": (0.0, 0.07),
        "rubber_shininess": (0.0, 0.09),
    },
    "heldout": {
        "metal_specular": (0.82, 1.0),
        "metal_shininess": (0.62, 1.0),
        "metal_body": (0.82, 1.0),
        "rubber_specular": (0.08, 0.16),
        "rubber_shininess": (0.10, 0.25),
    },
}
PALETTE_SHADE_JITTER = 0.06  # each paint channel scaled by 1 +- up to this (both families)
CRF_RANGE = (18, 30)  # h264 constant rate factor, both families (inclusive)
OBJECT_COUNT_RANGE = (3, 8)  # both families (inclusive); the default keeps 3-6
EDGE_SHARE = 0.15  # share of in-view objects placed partly out of view (both families)


@dataclass(frozen=True)
class FloorLook:
    """Floor appearance: ``texture`` in FLOOR_TEXTURES, base ``rgb`` and second
    colour ``rgb2`` (checker squares, speckles), ``tile`` m per texture repeat."""

    texture: str
    rgb: tuple[float, float, float]
    rgb2: tuple[float, float, float]
    tile: float
    specular: float

    def __post_init__(self):
        if self.texture not in FLOOR_TEXTURES:
            raise ValueError(f"texture: expected one of {FLOOR_TEXTURES}, got {self.texture!r}")
        for name in ("rgb", "rgb2"):
            value = getattr(self, name)
            if len(value) != 3 or not all(0.0 <= v <= 1.0 for v in value):
                raise ValueError(f"{name}: expected 3 values in [0, 1], got {value!r}")
        if not self.tile > 0:
            raise ValueError(f"tile: expected > 0 m, got {self.tile!r}")


@dataclass(frozen=True)
class LightLook:
    """Key light: comes from (``azimuth_deg``, ``elevation_deg``), diffuse
    ``intensity`` x ``tint``; ``ambient`` of the head light; ``shadows`` style."""

    azimuth_deg: float
    elevation_deg: float
    intensity: float
    tint: tuple[float, float, float]
    ambient: float
    shadows: str

    def __post_init__(self):
        if self.shadows not in SHADOW_STYLES:
            raise ValueError(f"shadows: expected one of {SHADOW_STYLES}, got {self.shadows!r}")
        if not 0.0 < self.elevation_deg <= 90.0:
            raise ValueError(f"elevation_deg: expected (0, 90], got {self.elevation_deg!r}")

    @property
    def direction(self) -> tuple[float, float, float]:
        """(3,) unit vector the light travels along (from the light towards the floor)."""
        az, el = math.radians(self.azimuth_deg), math.radians(self.elevation_deg)
        towards_light = np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
        return tuple(float(v) for v in -towards_light)


@dataclass(frozen=True)
class CameraLook:
    """Camera pose: ``distance`` m from the look-at ``target`` (3,) m on the floor,
    ``tilt_deg`` below the horizon, ``yaw_deg`` azimuth offset, ``fovy_deg``."""

    distance: float
    tilt_deg: float
    yaw_deg: float
    fovy_deg: float
    target: tuple[float, float, float]

    @property
    def height(self) -> float:
        """Camera height above the floor, m."""
        return self.distance * math.sin(math.radians(self.tilt_deg))


@dataclass(frozen=True)
class MaterialLook:
    """How the two materials render (MuJoCo material attributes, 0..1).

    ``metal_body``: metal's body colour is the paint times this factor.
    ``paint_shades``: (8, 3) per-colour channel factors, in the order of
    world.types.CLEVR_PALETTE_RGB, applied to the paint of both materials
    (results clipped to 1).
    """

    metal_specular: float
    metal_shininess: float
    metal_body: float
    rubber_specular: float
    rubber_shininess: float
    paint_shades: tuple[tuple[float, float, float], ...]

    def __post_init__(self):
        for name in ("metal_specular", "metal_shininess", "metal_body", "rubber_specular", "rubber_shininess"):
            value = getattr(self, name)
            if not 0.0 <= value <= 1.0:
                raise ValueError(f"{name}: expected a value in [0, 1], got {value!r}")
        if len(self.paint_shades) != len(CLEVR_PALETTE_RGB) or any(len(s) != 3 or min(s) <= 0 for s in self.paint_shades):
            raise ValueError(f"paint_shades: expected {len(CLEVR_PALETTE_RGB)} positive (r, g, b) factors")

    def paint(self, color: str) -> tuple[float, float, float]:
        """Linear 0..1 paint of colour name ``color`` after the shade jitter."""
        shade = self.paint_shades[list(CLEVR_PALETTE_RGB).index(color)]
        return tuple(min(c / 255.0 * f, 1.0) for c, f in zip(CLEVR_PALETTE_RGB[color], shade))


@dataclass(frozen=True)
class Look:
    """Everything about a scene's appearance that is not physics.

    ``floor``, ``light`` and ``camera`` are None for the default look (synth-1's
    fixed floor and lights; the camera drawn per scene draw by synth.scene).
    """

    family: str
    crf: int
    object_count: tuple[int, int]
    edge_share: float
    floor: FloorLook | None = None
    light: LightLook | None = None
    camera: CameraLook | None = None
    materials: MaterialLook | None = None  # None: the default look's metal and rubber (synth.mjcf)

    def __post_init__(self):
        if self.family not in LOOK_FAMILIES:
            raise ValueError(f"family: expected one of {LOOK_FAMILIES}, got {self.family!r}")
        if not CRF_RANGE[0] <= self.crf <= CRF_RANGE[1]:
            raise ValueError(f"crf: expected {CRF_RANGE[0]}..{CRF_RANGE[1]}, got {self.crf!r}")
        low, high = self.object_count
        if not 1 <= low <= high:
            raise ValueError(f"object_count: expected 1 <= low <= high, got {self.object_count!r}")
        if not 0.0 <= self.edge_share <= 1.0:
            raise ValueError(f"edge_share: expected [0, 1], got {self.edge_share!r}")
        if (self.family == "default") != (self.floor is None and self.light is None and self.camera is None and self.materials is None):
            raise ValueError("floor, light, camera, materials: None exactly for the default family")


DEFAULT_LOOK = Look(family="default", crf=18, object_count=(3, 6), edge_share=0.0)


def look_seed_sequence(seed: int, index: int, family: str) -> np.random.SeedSequence:
    return np.random.SeedSequence([seed, index, LOOK_STREAM, _FAMILY_CODE[family]])


def _in_bands(rng: np.random.Generator, bands: list[tuple[float, float]]) -> float:
    widths = np.array([b - a for a, b in bands])
    k = int(rng.choice(len(bands), p=widths / widths.sum()))
    return float(rng.uniform(*bands[k]))


def _between(rng: np.random.Generator, low, high) -> tuple[float, float, float]:
    """A colour on the segment from ``low`` to ``high`` (3,) (one draw: greys stay grey)."""
    t = float(rng.uniform())
    return tuple(float(a + t * (b - a)) for a, b in zip(low, high))


def sample_look(rng: np.random.Generator, family: str, camera_target: tuple[float, float, float]) -> Look:
    """Draw a look of ``family``; ``camera_target`` (3,) m is the nominal look-at point."""
    if family == "default":
        return DEFAULT_LOOK
    if family not in FLOOR_PRESETS:
        raise ValueError(f"--looks: expected one of {', '.join(LOOK_FAMILIES)}, got {family!r}")
    preset = FLOOR_PRESETS[family][int(rng.integers(len(FLOOR_PRESETS[family])))]
    base = _between(rng, preset["low"], preset["high"])
    floor = FloorLook(
        texture=preset["texture"],
        rgb=base,
        rgb2=tuple(float(v * preset["contrast"]) for v in base),
        tile=float(rng.uniform(0.5, 1.0)) if preset["texture"] in ("checker", "speckle") else 12.0,
        specular=float(rng.uniform(0.02, 0.2)),
    )
    ranges = LIGHT_RANGES[family]
    light = LightLook(
        azimuth_deg=float(rng.uniform(*ranges["azimuth_deg"])),
        elevation_deg=float(rng.uniform(*ranges["elevation_deg"])),
        intensity=float(rng.uniform(*ranges["intensity"])),
        tint=_between(rng, ranges["tint_low"], ranges["tint_high"]),
        ambient=float(rng.uniform(*ranges["ambient"])),
        shadows=str(rng.choice(SHADOW_STYLES)),
    )
    jitter = rng.uniform(-TARGET_JITTER, TARGET_JITTER, size=2)
    camera = CameraLook(
        distance=_in_bands(rng, camera_bands(family, "distance")),
        tilt_deg=_in_bands(rng, camera_bands(family, "tilt_deg")),
        yaw_deg=float(rng.uniform(*CAMERA_YAW_RANGE_DEG)),
        fovy_deg=_in_bands(rng, camera_bands(family, "fovy_deg")),
        target=(float(camera_target[0] + jitter[0]), float(camera_target[1] + jitter[1]), float(camera_target[2])),
    )
    crf = int(rng.integers(CRF_RANGE[0], CRF_RANGE[1] + 1))
    # Drawn last, so the floor, light and camera of a (seed, index) are those of looks before materials varied.
    ranges = MATERIAL_RANGES[family]
    materials = MaterialLook(
        **{name: float(rng.uniform(*ranges[name])) for name in ranges},
        paint_shades=tuple(tuple(float(v) for v in rng.uniform(1 - PALETTE_SHADE_JITTER, 1 + PALETTE_SHADE_JITTER, 3))
                           for _ in CLEVR_PALETTE_RGB),
    )
    return Look(family=family, crf=crf, object_count=OBJECT_COUNT_RANGE, edge_share=EDGE_SHARE, floor=floor, light=light,
                camera=camera, materials=materials)


def clevrer_floor_png() -> bytes:
    """The CLEVRER floor image (480x320 RGBA PNG, from the CLEVRER release's background.png)."""
    return resources.files("synth").joinpath("data", CLEVRER_FLOOR_FILE).read_bytes()


def rounded(value):
    """A JSON-able value with every float rounded to 5 decimals (compact ground-truth files; -0.0 -> 0.0)."""
    if isinstance(value, float):
        return round(value, 5) + 0.0
    if isinstance(value, (list, tuple)):
        return [rounded(v) for v in value]
    if isinstance(value, dict):
        return {k: rounded(v) for k, v in value.items()}
    return value


def look_document(look: Look) -> dict:
    """The look's parameters as JSON (ground_truth ``look``), rounded for compact files."""
    document = rounded(asdict(look))
    if look.materials is None:
        del document["materials"]  # the default look's documents stay those of synth-1/synth-2
    if look.light is not None:
        document["light"]["direction"] = rounded(list(look.light.direction))
    if look.camera is not None:
        document["camera"]["height"] = rounded(look.camera.height)
    return document


PAINT_JITTER = {"hue_deg": 5.0, "saturation": 0.08, "value": 0.08}  # +- per scene and colour (ray-traced looks)


def check_rgb(name: str, value) -> None:
    """Raise ValueError unless ``value`` is 3 floats in [0, 1] (a linear RGB colour)."""
    if len(value) != 3 or not all(0.0 <= v <= 1.0 for v in value):
        raise ValueError(f"{name}: expected 3 values in [0, 1], got {value!r}")


def uniform_in(rng: np.random.Generator, low_high: tuple[float, float]) -> float:
    """One float drawn uniformly from the closed range ``low_high``."""
    return float(rng.uniform(*low_high))


def jittered_paint(rng: np.random.Generator, hsv: tuple[float, float, float]) -> tuple[float, float, float]:
    """RGB in [0, 1] of a paint centred on ``hsv`` (hue deg, saturation, value), jittered by PAINT_JITTER.

    A grey (saturation 0) stays grey: only its value is jittered.
    """
    hue = (hsv[0] + rng.uniform(-1, 1) * PAINT_JITTER["hue_deg"]) % 360.0
    sat = hsv[1] if hsv[1] == 0 else float(np.clip(hsv[1] + rng.uniform(-1, 1) * PAINT_JITTER["saturation"], 0.0, 1.0))
    val = float(np.clip(hsv[2] + rng.uniform(-1, 1) * PAINT_JITTER["value"], 0.0, 1.0))
    return tuple(float(c) for c in colorsys.hsv_to_rgb(hue / 360.0, sat, val))
