"""Debug output a person can check by eye: contact sheet of frames with fitted masks, ids and attributes.

PNG written with numpy + zlib only; text drawn with a tiny built-in 3x5 pixel font.
"""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

import numpy as np

from perception.types import LiftedTrack
from world.camera import project
from world.types import Camera
from perception.pipeline import instance_map

_TRACK_COLOURS = np.array([[255, 64, 64], [64, 200, 255], [255, 220, 0], [120, 255, 120], [255, 128, 255],
                           [255, 160, 64], [160, 120, 255], [0, 255, 200]], dtype=np.uint8)
_SHORT = {"sphere": "SP", "cube": "CU", "cylinder": "CY", "rubber": "R", "metal": "M"}
# 3x5 glyphs, rows top to bottom, 3 bits each (1 = ink).
_FONT = {
    "0": "111101101101111", "1": "010110010010111", "2": "111001111100111", "3": "111001111001111",
    "4": "101101111001001", "5": "111100111001111", "6": "111100111101111", "7": "111001001001001",
    "8": "111101111101111", "9": "111101111001111", "A": "010101111101101", "B": "110101110101110",
    "C": "111100100100111", "D": "110101101101110", "E": "111100111100111", "F": "111100111100100",
    "G": "111100101101111", "H": "101101111101101", "I": "111010010010111", "K": "101101110101101",
    "L": "100100100100111", "M": "101111111101101", "N": "111101101101101", "O": "111101101101111",
    "P": "111101111100100", "R": "111101110101101", "S": "111100111001111", "T": "111010010010010",
    "U": "101101101101111", "W": "101101111111101", "Y": "101101111010010", "#": "101111101111101",
    " ": "000000000000000", "-": "000000111000000",
}


def write_png(path: Path, image: np.ndarray) -> None:
    """Write an (H, W, 3) uint8 RGB image as PNG."""
    data = png_bytes(image)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(data)


def png_bytes(image: np.ndarray) -> bytes:
    """An (H, W, 3) uint8 RGB image encoded as PNG."""
    if image.ndim != 3 or image.shape[2] != 3 or image.dtype != np.uint8:
        raise ValueError(f"image: expected (H, W, 3) uint8, got {image.shape} {image.dtype}")
    height, width, _ = image.shape
    raw = b"".join(b"\x00" + image[row].tobytes() for row in range(height))

    def chunk(tag: bytes, payload: bytes) -> bytes:
        return struct.pack(">I", len(payload)) + tag + payload + struct.pack(">I", zlib.crc32(tag + payload) & 0xFFFFFFFF)

    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b"")


def draw_text(image: np.ndarray, text: str, x: int, y: int, colour: np.ndarray, scale: int = 2) -> None:
    """Draw upper-case text in place at top-left (x, y), clipped to the image."""
    height, width, _ = image.shape
    for k, char in enumerate(text.upper()):
        glyph = _FONT.get(char, _FONT[" "])
        for bit, ink in enumerate(glyph):
            if ink == "1":
                gy, gx = divmod(bit, 3)
                top, left = y + gy * scale, x + (k * 4 + gx) * scale
                if 0 <= top < height - scale and 0 <= left < width - scale:
                    image[top:top + scale, left:left + scale] = colour


def overlay(frame: np.ndarray, instance: np.ndarray, lifted: list[LiftedTrack], frame_index: int, camera: Camera) -> np.ndarray:
    """Frame with each track's fitted silhouette tinted and outlined, labelled 'id colour shape material'."""

    out = frame.copy()
    for track in lifted:
        mask = instance == track.id
        if not mask.any():
            continue
        colour = _TRACK_COLOURS[track.id % len(_TRACK_COLOURS)]
        out[mask] = (0.6 * out[mask] + 0.4 * colour).astype(np.uint8)
        edge = mask & ~(np.roll(mask, 1, 0) & np.roll(mask, -1, 0) & np.roll(mask, 1, 1) & np.roll(mask, -1, 1))
        out[edge] = colour
        k = int(np.nonzero(track.frames == frame_index)[0][0])
        u, v = project(camera, track.positions[k])
        a = track.attributes
        label = f"{track.id} {a.color[:3]} {_SHORT[a.shape]} {_SHORT[a.material]}"
        draw_text(out, label, int(u) - 20, int(v) + 22, colour)
    draw_text(out, f"F{frame_index}", 4, 4, np.array([0, 0, 0], np.uint8))
    return out


def contact_sheet(frames: np.ndarray, lifted: list[LiftedTrack], camera: Camera, picks: list[int], columns: int = 4) -> np.ndarray:
    """Tile overlays of the chosen frames into one image."""
    tiles = [overlay(frames[f], instance_map(camera, lifted, f), lifted, f, camera) for f in picks]
    height, width, _ = tiles[0].shape
    rows = (len(tiles) + columns - 1) // columns
    sheet = np.full((rows * (height + 4) - 4, columns * (width + 4) - 4, 3), 255, dtype=np.uint8)
    for k, tile in enumerate(tiles):
        r, c = divmod(k, columns)
        sheet[r * (height + 4):r * (height + 4) + height, c * (width + 4):c * (width + 4) + width] = tile
    return sheet


def write_debug(directory: Path, frames: np.ndarray, lifted: list[LiftedTrack], camera: Camera, count: int = 8) -> list[Path]:
    """Write contact_sheet.png (``count`` evenly spaced frames) and tracks.txt into ``directory``."""
    directory.mkdir(parents=True, exist_ok=True)
    picks = sorted(set(np.linspace(0, frames.shape[0] - 1, count).round().astype(int).tolist()))
    sheet = directory / "contact_sheet.png"
    write_png(sheet, contact_sheet(frames, lifted, camera, picks))
    summary = directory / "tracks.txt"
    lines = ["id color shape material first_frame last_frame frames mean_weight shape_score metal_probability"]
    for t in lifted:
        a = t.attributes
        lines.append(f"{t.id} {a.color} {a.shape} {a.material} {int(t.frames[0])} {int(t.frames[-1])} {len(t.frames)} "
                     f"{float(np.mean(t.weights)):.2f} {a.shape_score:.2f} {a.metal_probability:.2f}")
    summary.write_text("\n".join(lines) + "\n")
    return [sheet, summary]
