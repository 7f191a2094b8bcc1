"""Physion from video, first step: 3D lifting of the airborne agent with the ballistic constraint.

For every bounce_wall trial of a ``physmind synth --suite physion`` data set
(with videos and cameras): the agent's first arc (from frame 0 to the frame
before its first impact, found from the annotation: an oracle segmentation of
the arc) is lifted to 3D by ``perception.lift3d.ballistic_lift`` twice:

* from the oracle pixels (the annotation's 3D centres projected through the
  camera): the lifting itself, without detection error;
* from the video (the centroid of the red pixels of each frame):
  detection plus lifting.

Prints per source the median and 90th percentile of the 3D position RMSE over
the arc (m), of the error of the initial velocity (m/s) and of the depth
error at the first frame (m, along the viewing ray), and the median pixel
offset of the red centroid from the projected centre.

Usage:
    python -m bench.bench_lift3d DATASET_DIR [--limit N]
"""

from __future__ import annotations

import argparse
import statistics
from pathlib import Path

import numpy as np

from perception.lift3d import ballistic_lift, colour_centres
from physmind.physion_eval import load_trials
from synth.render import read_mp4
from world.camera import project, project_with_depth
from world.io import load_camera, read_json_file
from world.types import STANDARD_GRAVITY

BALLISTIC_TOLERANCE = 2.0  # m/s^2: a second difference this far from gravity marks the first impact


def first_arc(annotation: dict) -> tuple[np.ndarray, np.ndarray]:
    """Frames (K,) and the agent's annotated centres (K, 3) from frame 0 up to its first impact."""
    agent = next(o["object_id"] for o in annotation["object_property"] if o.get("role") == "agent")
    by_frame = {f["frame_id"]: {o["object_id"]: o["location"] for o in f["objects"]} for f in annotation["motion_trajectory"]}
    frames = sorted(f for f in by_frame if agent in by_frame[f])
    centres = np.array([by_frame[f][agent] for f in frames])
    dt = 1.0 / annotation.get("fps", 25.0)
    second = (centres[2:] - 2 * centres[1:-1] + centres[:-2]) / dt**2
    second[:, 2] += STANDARD_GRAVITY
    odd = np.nonzero(np.linalg.norm(second, axis=1) > BALLISTIC_TOLERANCE)[0]
    end = int(odd[0]) + 1 if len(odd) else len(frames)  # frame end-1 is the last one before the impact
    return np.array(frames[:end]), centres[:end]


def errors(arc, camera, times: np.ndarray, truth: np.ndarray, v_truth: np.ndarray) -> tuple[float, float, float]:
    fitted = arc.positions(times)
    rmse = float(np.sqrt(np.mean(np.sum((fitted - truth) ** 2, axis=1))))
    _, depth_fit = project_with_depth(camera, fitted[:1])
    _, depth_true = project_with_depth(camera, truth[:1])
    return rmse, float(np.linalg.norm(arc.v0 - v_truth)), float(abs(depth_fit[0] - depth_true[0]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dataset", type=Path)
    parser.add_argument("--limit", type=int, default=None)
    args = parser.parse_args()
    trials = [t for t in load_trials(args.dataset) if t["category"] == "bounce_wall"][: args.limit]
    rows: dict[str, list] = {"oracle pixels": [], "video (red centroid)": []}
    offsets, lengths = [], []
    for trial in trials:
        index = int(trial["index"])
        annotation = read_json_file(args.dataset / "annotations" / f"annotation_{index:05d}.json", "annotation")
        camera = load_camera(args.dataset / "cameras" / f"camera_{index:05d}.json")
        frames, truth = first_arc(annotation)
        times = frames / annotation.get("fps", 25.0)
        v_truth = next(o["velocity"] for o in annotation["motion_trajectory"][int(frames[0])]["objects"] if o["object_id"] == 0)
        oracle = project(camera, truth)
        video = colour_centres(read_mp4(args.dataset / "videos" / trial["video_filename"])[frames])
        offsets.append(float(np.nanmedian(np.linalg.norm(video - oracle, axis=1))))
        lengths.append(len(frames))
        for name, pixels in (("oracle pixels", oracle), ("video (red centroid)", video)):
            rows[name].append(errors(ballistic_lift(camera, times, pixels), camera, times, truth, np.asarray(v_truth)))
    print(f"{len(trials)} bounce_wall trials; first arc {min(lengths)}-{max(lengths)} frames (median {statistics.median(lengths)}); "
          f"red centroid vs projected centre: median {statistics.median(offsets):.2f} px")
    print(f"{'pixels':<22}{'rmse med m':>12}{'rmse p90 m':>12}{'|dv0| med':>11}{'|dv0| p90':>11}{'depth med m':>13}{'depth p90 m':>13}")
    for name, values in rows.items():
        columns = list(zip(*values))
        cells = []
        for column in columns:
            ordered = sorted(column)
            cells += [statistics.median(ordered), ordered[int(0.9 * (len(ordered) - 1))]]
        print(f"{name:<22}{cells[0]:>12.4f}{cells[1]:>12.4f}{cells[2]:>11.3f}{cells[3]:>11.3f}{cells[4]:>13.4f}{cells[5]:>13.4f}")


if __name__ == "__main__":
    main()
