"""Per-tracklet attribute samples of generated scenes: what the attribute rules see, with the truth.

Usage:
  MUJOCO_GL=egl python -m bench.attribute_samples DIR CACHE_DIR [--limit N]

Runs perception on each video of DIR (a `physmind synth` output) and stores,
per scene, one pickle in CACHE_DIR holding for every tracklet that the lifter
kept: the appearance windows (perception.material_model.AppearanceWindow of the
frames the pipeline decides colour and material on), the per-frame primitive
overlaps (shape), the colour votes, and the true colour / shape / material of
the object whose true masks cover most of the tracklet's pixels (None when no
object does). Used by bench.train_attributes (training and per-object
diagnosis) and never by the pipeline.
"""

from __future__ import annotations

import argparse
import json
import pickle
import sys
from pathlib import Path

import numpy as np
from tqdm import tqdm

from perception.attributes import color_votes
from perception.background import AMBIGUOUS, FLOOR, is_foreground
from perception.geometry import silhouette
from perception.material_model import appearance_windows
from perception.pipeline import PrimitiveLifter, _appearance_frames, _isolated_frames, perceive_frames
from perception.video import read_video
from synth.masks import decode_mask
from world.io import load_camera


class RecordingLifter(PrimitiveLifter):
    """The pipeline's lifter, keeping each tracklet's per-frame primitive overlaps (by track id) and, per
    frame and kind, the pixel counts of the fitted silhouette S: (|S & D|, |S & floor|, |S & ambiguous|,
    |S & other objects|, |D|) with D the detection."""

    def __init__(self) -> None:
        super().__init__()
        self.shape_record: dict[int, dict[str, list[float]]] = {}
        self.count_record: dict[int, dict[str, list[tuple[int, ...]]]] = {}
        self._counts: dict[str, list[tuple[int, ...]]] = {}

    def shape_fits(self, camera, detection, labels, free_top=False, reach=None):
        fits = super().shape_fits(camera, detection, labels, free_top, reach)
        for kind, fit in fits.items():
            window, sil = silhouette(camera, kind, fit.centre, self.size, fit.yaw)
            counts = (0, 0, 0, 0, detection.area)
            if not window.empty:
                region = labels[window.top:window.bottom, window.left:window.right]
                mine = np.zeros_like(sil)
                ys, xs = detection.ys - window.top, detection.xs - window.left
                ok = (ys >= 0) & (ys < sil.shape[0]) & (xs >= 0) & (xs < sil.shape[1])
                mine[ys[ok], xs[ok]] = True
                counts = (int((sil & mine).sum()), int((sil & (region == FLOOR)).sum()), int((sil & (region == AMBIGUOUS)).sum()),
                          int((sil & ~mine & is_foreground(region)).sum()), detection.area)
            self._counts.setdefault(kind, []).append(counts)
        return fits

    def shape_scores(self, camera, track, segments, frames_used, frames, free_top=False, reach=None):
        self._counts = {}
        scores = super().shape_scores(camera, track, segments, frames_used, frames, free_top, reach)
        self.shape_record[track.id], self.count_record[track.id] = scores, self._counts
        return scores


def scene_samples(root: Path, index: int) -> dict:
    """Samples of one scene: {"scene", "look", "tracks": [...]} (see the module docstring)."""
    name = f"{index:05d}"
    camera = load_camera(root / "ground_truth" / f"scene_{name}.json")
    frames, fps = read_video(root / "videos" / f"video_{name}.mp4")
    lifter = RecordingLifter()
    _, inter = perceive_frames(frames, camera, fps=fps, lifter=lifter)
    segments = inter["segments"]
    document = json.loads((root / "masks" / f"proposal_{name}.json").read_text())
    truth_of, masks = {}, []
    for frame in document["frames"]:
        masks.append({o["object_id"]: o["mask"] for o in frame["objects"]})
        for o in frame["objects"]:
            truth_of[o["object_id"]] = (o["color"], o["shape"], o["material"])
    rows = []
    for track in inter["tracks"]:
        if track.id not in lifter.shape_record:
            continue
        isolated = _isolated_frames(track, segments)
        chosen = _appearance_frames(track, segments)  # the frames perception itself decides colour and material on
        detections = [track.detections[f] for f in chosen]
        votes: dict[int, int] = {}
        for det in detections:
            for oid, rle in masks[det.frame].items():
                votes[oid] = votes.get(oid, 0) + int(decode_mask(rle)[det.ys, det.xs].sum())
        truth = None
        if votes and max(votes.values()) > 0.5 * sum(d.area for d in detections):
            oid = max(votes, key=votes.get)
            truth = {"color": truth_of[oid][0], "shape": truth_of[oid][1], "material": truth_of[oid][2], "object": oid}
        rows.append({"track": track.id, "truth": truth, "frames": len(track.detections), "isolated": len(isolated),
                     "shape_scores": lifter.shape_record[track.id], "shape_counts": lifter.count_record[track.id], "color_votes": color_votes(detections, frames),
                     "windows": appearance_windows(detections, frames, segments)})
    look = json.loads((root / "ground_truth" / f"scene_{name}.json").read_text()).get("look") or {}
    return {"scene": index, "root": str(root), "look": look, "tracks": rows}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("root", type=Path)
    parser.add_argument("cache", type=Path)
    parser.add_argument("--limit", type=int, default=None)
    args = parser.parse_args(argv)
    indices = sorted(int(p.stem.split("_")[1]) for p in (args.root / "videos").glob("video_*.mp4"))
    indices = [i for i in indices if (args.root / "masks" / f"proposal_{i:05d}.json").exists()][: args.limit]
    if not indices:
        print(f"{args.root}: no video with masks", file=sys.stderr)
        return 2
    args.cache.mkdir(parents=True, exist_ok=True)
    for index in tqdm(indices, desc="samples", unit="scene"):
        target = args.cache / f"{index:05d}.pkl"
        if not target.exists():
            target.write_bytes(pickle.dumps(scene_samples(args.root, index)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
