"""Grey objects keep their shape on a floor brighter than their paint: a hue-less object's lit faces are then
shadow-like (the floor's chroma, darker than the floor) and must not count against the primitive that covers
them (attributes.shape_overlap).

Scenes drawn in the test (a seed no tuning used; held-out looks: lights, cameras and compression perception was
not tuned on) on a bright flat floor, every object painted grey, simulated and rendered by MuJoCo, encoded to
h264 and perceived; each perceived track is matched to the object it follows (mean planar distance) and its shape
compared with the generator's. Main (ambiguous pixels counted against grey objects too) read 47 of 55 right here.
Grey top faces as bright as the floor are labelled floor and still lost (docs/perception.md, known limits)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from perception.pipeline import perceive_frames
from perception.video import read_video
from synth.generate import scene_draws
from synth.render import render_scene, write_mp4
from synth.simulate import simulate

SEED = 902171  # used by no fixture, no benchmark and no tuning
SCENES = range(10)
MATCH_M = 0.3  # a track follows an object when its mean planar distance to it is below this
MIN_TRACK_SAMPLES = 10
MIN_RIGHT_SHARE = 0.9
FLOOR_GREY = 0.8  # rgb of the flat floor: brighter than the lit faces of grey paint


def _grey_scene(tmp_path, index: int):
    """(objects, sim, observations) of the first draw of (SEED, index) in a held-out look on a bright flat floor,
    every object grey."""
    spec = next(scene_draws(SEED, index, "heldout")[2])
    floor = replace(spec.look.floor, texture="flat", rgb=(FLOOR_GREY,) * 3, rgb2=(FLOOR_GREY,) * 3)
    spec = replace(spec, look=replace(spec.look, floor=floor), objects=tuple(replace(o, color="gray") for o in spec.objects))
    sim = simulate(spec, horizon_frames=spec.observed_frames)
    rgb, _ = render_scene(spec, sim)
    path = tmp_path / f"grey_{index}.mp4"
    write_mp4(path, rgb, spec.fps, spec.look.crf)
    frames, fps = read_video(path)
    observations, _ = perceive_frames(frames, spec.camera, fps=fps)
    return spec.objects, sim, observations


def _followed_object(track, sim) -> int | None:
    """Index (into sim.object_ids) of the object the track follows, None when it follows none."""
    frames = track.frames[track.observed]
    distances = [float(np.mean(np.linalg.norm(track.positions[track.observed, :2] - sim.positions[frames, k, :2], axis=1)))
                 for k in range(len(sim.object_ids))]
    best = int(np.argmin(distances))
    return best if distances[best] < MATCH_M else None


@pytest.mark.slow
def test_grey_objects_are_perceived_with_their_shape(tmp_path):
    judged, right, wrong = 0, 0, []
    for index in SCENES:
        objects, sim, observations = _grey_scene(tmp_path, index)
        shapes = {o.object_id: o.shape for o in objects}
        for track in observations.objects:
            k = _followed_object(track, sim) if track.observed.sum() >= MIN_TRACK_SAMPLES else None
            if k is None:
                continue
            judged += 1
            truth = shapes[sim.object_ids[k]]
            if track.shape.kind == truth:
                right += 1
            else:
                wrong.append(f"scene {index} object {sim.object_ids[k]}: {truth} read as {track.shape.kind}")
    assert judged >= 30, f"only {judged} grey objects followed"
    assert right >= MIN_RIGHT_SHARE * judged, f"{right}/{judged} grey objects with their shape; " + "; ".join(wrong)
