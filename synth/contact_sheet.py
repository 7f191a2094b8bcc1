"""Contact sheets: grids of video frames (written as PNG by perception.debug.write_png)."""

from __future__ import annotations

import numpy as np


def tile(images: list[np.ndarray], columns: int, gap: int = 4) -> np.ndarray:
    """Tile equal-size (H, W, 3) images row-major into one image with white gaps."""
    if not images:
        raise ValueError("images: nothing to tile")
    height, width, _ = images[0].shape
    rows = (len(images) + columns - 1) // columns
    sheet = np.full((rows * (height + gap) - gap, columns * (width + gap) - gap, 3), 255, dtype=np.uint8)
    for k, image in enumerate(images):
        r, c = divmod(k, columns)
        sheet[r * (height + gap) : r * (height + gap) + height, c * (width + gap) : c * (width + gap) + width] = image
    return sheet
