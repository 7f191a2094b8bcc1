"""Which perceived track covers each true object, judged by the generator's instance masks."""

from __future__ import annotations

import numpy as np

from perception.pipeline import instance_map
from synth.masks import decode_mask

MIN_MASK_AREA = 50  # px: smaller masks are too few pixels to judge an IoU
MIN_IOU = 0.5


def whole_in_view_coverage(camera, lifted, masks) -> dict[int, list[tuple[int, int]]]:
    """true object id -> (frame, perceived id) on every frame where the object is whole in view (its mask
    touches no image border); the perceived id is -1 when no track's mask has IoU >= MIN_IOU with it."""
    covering: dict[int, list[tuple[int, int]]] = {}
    for entry in masks:
        frame = entry["frame_index"]
        ids = instance_map(camera, lifted, frame)
        for obj in entry["objects"]:
            mask = decode_mask(obj["mask"])
            if obj["area"] < MIN_MASK_AREA or mask[0].any() or mask[-1].any() or mask[:, 0].any() or mask[:, -1].any():
                continue
            best = (0.0, -1)
            for pid in np.unique(ids[mask]):
                if pid >= 0:
                    perceived = ids == pid
                    best = max(best, ((perceived & mask).sum() / (perceived | mask).sum(), int(pid)))
            covering.setdefault(obj["object_id"], []).append((frame, best[1] if best[0] >= MIN_IOU else -1))
    return covering
