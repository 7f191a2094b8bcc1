"""COCO run-length encoding of binary masks, in numpy (no pycocotools).

COCO's RLE runs over the pixels in column-major order (down each column, then
the next column), alternating runs of 0s and 1s and starting with a run of 0s
(possibly empty). The compressed ``counts`` string stores each run as a
little-endian base-32 varint of 5-bit groups offset by ASCII 48, with a
continuation bit 0x20 and a sign bit 0x10 on the last group; from the third
run on, the difference to the run two places earlier is stored instead.
"""

from __future__ import annotations

import numpy as np


def runs_from_mask(mask: np.ndarray) -> list[int]:
    """Run lengths of an (H, W) bool mask in column-major order, starting with 0s."""
    flat = np.asarray(mask, dtype=bool).flatten(order="F")
    if flat.size == 0:
        return [0]
    change = np.flatnonzero(flat[1:] != flat[:-1]) + 1
    boundaries = np.concatenate([[0], change, [flat.size]])
    runs = np.diff(boundaries).tolist()
    if flat[0]:
        runs = [0] + runs
    return [int(r) for r in runs]


def mask_from_runs(runs: list[int], height: int, width: int) -> np.ndarray:
    """Inverse of :func:`runs_from_mask`: (H, W) bool mask."""
    if sum(runs) != height * width:
        raise ValueError(f"counts: runs add up to {sum(runs)} pixels, expected {height * width}")
    values = np.zeros(len(runs), dtype=bool)
    values[1::2] = True
    return np.repeat(values, runs).reshape((width, height)).T


def encode_counts(runs: list[int]) -> str:
    """COCO's compressed string form of run lengths."""
    out = []
    for k, run in enumerate(runs):
        x = run - runs[k - 2] if k > 2 else run
        more = True
        while more:
            c = x & 0x1F
            x >>= 5  # arithmetic shift: negative deltas end at -1
            more = (x != -1) if (c & 0x10) else (x != 0)
            if more:
                c |= 0x20
            out.append(chr(c + 48))
    return "".join(out)


def decode_counts(counts: str) -> list[int]:
    """Inverse of :func:`encode_counts`."""
    runs: list[int] = []
    position = 0
    while position < len(counts):
        x, shift, more = 0, 0, True
        while more:
            c = ord(counts[position]) - 48
            x |= (c & 0x1F) << (5 * shift)
            more = bool(c & 0x20)
            position += 1
            shift += 1
            if not more and (c & 0x10):
                x |= -1 << (5 * shift)
        if len(runs) > 2:
            x += runs[-2]
        runs.append(x)
    return runs


def encode_mask(mask: np.ndarray) -> dict:
    """COCO RLE of an (H, W) bool mask: ``{"size": [H, W], "counts": str}``."""
    height, width = mask.shape
    return {"size": [int(height), int(width)], "counts": encode_counts(runs_from_mask(mask))}


def decode_mask(rle: dict) -> np.ndarray:
    """(H, W) bool mask from a COCO RLE dict with a compressed ``counts`` string."""
    height, width = rle["size"]
    return mask_from_runs(decode_counts(rle["counts"]), int(height), int(width))


def bbox_of(mask: np.ndarray) -> list[int]:
    """[x, y, w, h] in pixels (COCO convention) of a non-empty mask."""
    ys, xs = np.nonzero(mask)
    return [int(xs.min()), int(ys.min()), int(xs.max() - xs.min() + 1), int(ys.max() - ys.min() + 1)]
