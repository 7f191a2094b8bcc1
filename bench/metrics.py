"""Scoring a fitted world against the generator's MuJoCo ground truth.

Shared by the identification, perception and question-answering benchmarks
and by their tests. Ground truth is always MuJoCo's (synth/), never ours.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable, Mapping, Sequence

import numpy as np

from world.io import camera_from_dict
from world.types import Camera, Edit, Rollout, World

EVENT_TOLERANCE_FRAMES = 5  # event precision/recall tolerance (docs/benchmarks.md)


@dataclass(frozen=True)
class PrecisionRecall:
    true_positives: int
    predicted: int
    actual: int

    def counts(self) -> list[int]:
        """[true positives, predicted, actual] (the JSON form of the benches)."""
        return [self.true_positives, self.predicted, self.actual]

    @property
    def precision(self) -> float:
        return self.true_positives / self.predicted if self.predicted else 1.0

    @property
    def recall(self) -> float:
        return self.true_positives / self.actual if self.actual else 1.0

    @property
    def f1(self) -> float:
        p, r = self.precision, self.recall
        return 2 * p * r / (p + r) if p + r else 0.0

    def __add__(self, other: "PrecisionRecall") -> "PrecisionRecall":
        return PrecisionRecall(
            self.true_positives + other.true_positives, self.predicted + other.predicted, self.actual + other.actual
        )


def unmatched_events(
    side: Sequence[tuple[tuple[int, int], int]],
    other: Sequence[tuple[tuple[int, int], int]],
    tolerance: int = EVENT_TOLERANCE_FRAMES,
) -> list[tuple[tuple[int, int], int]]:
    """Events of ``side`` with no event of the same pair in ``other`` within ``tolerance`` frames
    (greedy one-to-one, in time order, each taking the nearest free match)."""
    pool = list(other)
    left = []
    for pair, frame in sorted(side, key=lambda item: item[1]):
        candidates = [k for k, (p, f) in enumerate(pool) if p == pair and abs(f - frame) <= tolerance]
        if candidates:
            pool.pop(min(candidates, key=lambda k: abs(pool[k][1] - frame)))
        else:
            left.append((pair, frame))
    return left


def match_events(
    predicted: Sequence[tuple[tuple[int, int], int]],
    actual: Sequence[tuple[tuple[int, int], int]],
    tolerance: int = EVENT_TOLERANCE_FRAMES,
) -> PrecisionRecall:
    """Greedy one-to-one matching of (pair, frame) events with the same pair within ``tolerance`` frames."""
    hits = len(predicted) - len(unmatched_events(predicted, actual, tolerance))
    return PrecisionRecall(hits, len(predicted), len(actual))


def collision_set_score(predicted: Iterable[tuple[int, int]], actual: Iterable[tuple[int, int]]) -> PrecisionRecall:
    """Compare the SETS of colliding pairs (counterfactual metric)."""
    p, a = set(predicted), set(actual)
    return PrecisionRecall(len(p & a), len(p), len(a))


def rollout_collisions(rollout: Rollout, first_frame: int = 0, last_frame: int | None = None) -> list[tuple[tuple[int, int], int]]:
    """(sorted pair, frame) of the rollout's collisions with first_frame <= frame <= last_frame."""
    last = rollout.horizon_frames - 1 if last_frame is None else last_frame
    return [
        (tuple(sorted(e.bodies)), e.frame)
        for e in rollout.events
        if e.kind == "collision" and first_frame <= e.frame <= last
    ]


@dataclass(frozen=True)
class GroundTruth:
    """The parts of ``ground_truth/scene_XXXXX.json`` the benchmarks use."""

    scene_index: int
    observed_frames: int
    horizon_frames: int
    camera: Camera
    collisions: tuple[tuple[tuple[int, int], int], ...]
    counterfactual: Mapping[int, tuple[tuple[tuple[int, int], int], ...]]
    positions: np.ndarray  # (T, N, 3) metres, objects in ``object_ids`` order
    object_ids: tuple[int, ...]

    @classmethod
    def load(cls, path: str | Path) -> "GroundTruth":
        document = json.loads(Path(path).read_text())

        def collisions(events: list) -> tuple:
            return tuple(
                (tuple(sorted(e["object_ids"])), int(e["frame_id"])) for e in events if e["kind"] == "collision"
            )

        camera = camera_from_dict(document["camera"])
        objects = document["trajectory"]["objects"]
        return cls(
            scene_index=int(document["scene_index"]),
            observed_frames=int(document["observed_frames"]),
            horizon_frames=int(document["horizon_frames"]),
            camera=camera,
            collisions=collisions(document["events"]),
            counterfactual={int(c["removed_object_id"]): collisions(c["events"]) for c in document["counterfactual"]},
            positions=np.stack([np.asarray(o["location"], dtype=float) for o in objects], axis=1),
            object_ids=tuple(int(o["object_id"]) for o in objects),
        )


@dataclass(frozen=True)
class SceneScore:
    """One fitted world scored against MuJoCo.

    rmse: observed-window position RMSE (m) over visible frames;
    predictive: collisions after the video (5-frame tolerance);
    counterfactual: per removed object, the collision-SET score.
    """

    rmse: float
    predictive: PrecisionRecall
    counterfactual: tuple[PrecisionRecall, ...]
    observed: PrecisionRecall


def score_world(world: World, truth: GroundTruth, simulate, visible: np.ndarray | None = None) -> SceneScore:
    """Score ``world`` with ``simulate(world, edits, horizon_frames) -> Rollout``.

    visible: optional (T_obs, N) bool mask of frames to include in the RMSE
    (in ``truth.object_ids`` order); default: all observed frames.
    """
    horizon = truth.horizon_frames
    base = simulate(world, (), horizon)
    column = {body: k for k, body in enumerate(base.body_ids)}
    errors = []
    for k, object_id in enumerate(truth.object_ids):
        if object_id not in column:
            continue
        frames = np.arange(truth.observed_frames)
        if visible is not None:
            frames = frames[visible[: truth.observed_frames, k]]
        active = base.active[frames, column[object_id]]
        frames = frames[active]
        delta = base.positions[frames, column[object_id], :2] - truth.positions[frames, k, :2]
        errors.append(np.sum(delta**2, axis=1))
    rmse = float(np.sqrt(np.mean(np.concatenate(errors)))) if errors else float("nan")
    observed_end = truth.observed_frames - 1
    predictive = match_events(
        rollout_collisions(base, truth.observed_frames),
        [c for c in truth.collisions if c[1] > observed_end],
    )
    observed = match_events(
        rollout_collisions(base, 0, observed_end), [c for c in truth.collisions if c[1] <= observed_end]
    )
    counterfactual = []
    for removed, actual in sorted(truth.counterfactual.items()):
        if removed not in column:
            continue
        replay = simulate(world, (Edit("remove_object", removed),), horizon)
        counterfactual.append(
            collision_set_score([p for p, _ in rollout_collisions(replay)], [p for p, _ in actual])
        )
    return SceneScore(rmse, predictive, tuple(counterfactual), observed)
