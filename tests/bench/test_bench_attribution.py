"""bench/bench_attribution.py: each swap replaces exactly one perception output by the oracle's.

A "perceived" scene is made from a fixture's oracle tracks with known damage
(noise, wrong attributes, a fragmented and a late track, swapped labels);
each swap must give back the oracle's value of its output and keep the damage
elsewhere.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from bench.bench_attribution import (
    Truth,
    identification_table,
    match_tracks,
    relabel,
    swap_attributes,
    swap_entry_exit,
    swap_identities,
    swap_positions,
    true_candidates,
)
from world.observations import Observations, default_shape
from world.types import AttributeBelief

DATA = Path(__file__).resolve().parents[2] / "tests" / "data" / "synth"
SCENE = 0


@pytest.fixture(scope="module")
def scene():
    document = json.loads((DATA / "ground_truth" / f"scene_{SCENE:05d}.json").read_text())
    oracle = Observations.from_clevrer_annotation(DATA / "annotations" / f"annotation_{SCENE:05d}.json")
    return Truth(document), oracle


WRONG = {"color": "purple", "material": "metal", "shape": "cube"}


def damaged(oracle: Observations, rng: np.random.Generator) -> tuple[Observations, dict[int, int]]:
    """Noisy positions (3 cm), wrong attributes, labels 50+, object 0 split into two
    tracks at frame 60, the last object's track starting 10 frames late.
    Returns the damaged observations and the intended label -> object map."""
    tracks, labels = [], {}
    for k, track in enumerate(oracle.objects):
        noisy = track.positions + np.concatenate([rng.normal(0, 0.03, (len(track.frames), 2)), np.zeros((len(track.frames), 1))], axis=1)
        wrong = replace(track, positions=noisy, color=WRONG["color"] if track.color != WRONG["color"] else "gray",
                        material="rubber" if track.material == "metal" else "metal",
                        shape=default_shape("sphere" if track.shape.kind != "sphere" else "cube"))
        if k == 0:
            cut = 60
            first = replace(wrong, id=50, frames=wrong.frames[:cut], positions=wrong.positions[:cut], yaw=wrong.yaw[:cut], visible=wrong.visible[:cut], weights=wrong.weights[:cut])
            second = replace(wrong, id=90, frames=wrong.frames[cut:], positions=wrong.positions[cut:], yaw=wrong.yaw[cut:], visible=wrong.visible[cut:], weights=wrong.weights[cut:])
            tracks += [first, second]
            labels[50] = track.id
        elif k == len(oracle.objects) - 1:
            late = wrong.weights.copy()
            late[np.flatnonzero(late > 0)[:10]] = 0.0
            tracks.append(replace(wrong, id=50 + k, weights=late))
            labels[50 + k] = track.id
        else:
            tracks.append(replace(wrong, id=50 + k))
            labels[50 + k] = track.id
    return replace(oracle, objects=tuple(tracks)), labels


def test_tracks_are_matched_to_their_objects(scene):
    truth, oracle = scene
    perceived, labels = damaged(oracle, np.random.default_rng(0))
    assignment = match_tracks(perceived, truth)
    for label, object_id in labels.items():
        assert assignment[label] == object_id
    assert 90 not in assignment  # the second fragment: one track per object
    renamed = relabel(perceived, assignment)
    assert sorted(t.id for t in renamed.objects) == sorted([*labels.values(), 190])


def test_swap_identities_regroups_fragments_and_keeps_perceived_positions(scene):
    truth, oracle = scene
    perceived, labels = damaged(oracle, np.random.default_rng(1))
    swapped = swap_identities(perceived, truth)
    oracle_by_id = {t.id: t for t in oracle.objects}
    assert sorted(t.id for t in swapped.objects) == sorted(oracle_by_id)  # one track per object, fragments joined
    first = next(t for t in swapped.objects if t.id == labels[50])
    seen = oracle_by_id[labels[50]]
    assert set(first.frames.tolist()) == set(seen.frames[seen.observed].tolist())
    # positions are still the perceived (noisy) ones, attributes the perceived ones
    assert np.abs(first.positions[:, :2] - seen.positions[np.isin(seen.frames, first.frames), :2]).max() > 0.01
    assert first.color == WRONG["color"] or first.color == "gray"


def test_swap_positions_gives_the_true_positions_only(scene):
    truth, oracle = scene
    perceived, labels = damaged(oracle, np.random.default_rng(2))
    renamed = relabel(perceived, match_tracks(perceived, truth))
    swapped = swap_positions(renamed, truth)
    oracle_by_id = {t.id: t for t in oracle.objects}
    for track in swapped.objects:
        object_id = track.id if track.id < 100 else labels[50]
        reference = oracle_by_id[object_id]
        used = track.observed
        rows = np.searchsorted(reference.frames, track.frames[used])
        assert np.abs(track.positions[used, :2] - reference.positions[rows, :2]).max() < 1e-9
        assert track.color != next(t for t in oracle.objects if t.id == object_id).color or track.color == "gray"


def test_swap_attributes_gives_the_true_attributes_only(scene):
    truth, oracle = scene
    perceived, labels = damaged(oracle, np.random.default_rng(3))
    assignment = match_tracks(perceived, truth)
    renamed = relabel(perceived, assignment)
    ids = {t.id: t.id for t in renamed.objects if t.id < 100}
    belief = AttributeBelief.from_mappings({"red": 1.0}, {"metal": 1.0}, {"cube": 1.0}, support_frames=3)
    renamed = replace(renamed, objects=tuple(replace(t, attribute_belief=belief) for t in renamed.objects))
    swapped = swap_attributes(renamed, truth, ids)
    for track in swapped.objects:
        if track.id >= 100:
            assert track.attribute_belief == belief  # unmatched: perceived attributes and belief kept
            continue
        color, material, shape = truth.attributes[track.id]
        assert (track.color, track.material, track.shape.kind) == (color, material, shape)
        assert track.attribute_belief is None  # the true attributes are certain
        original = next(t for t in renamed.objects if t.id == track.id)
        assert np.array_equal(track.positions, original.positions)


def test_swap_entry_exit_covers_exactly_the_frames_in_view(scene):
    truth, oracle = scene
    perceived, labels = damaged(oracle, np.random.default_rng(4))
    renamed = relabel(perceived, match_tracks(perceived, truth))
    ids = {t.id: t.id for t in renamed.objects if t.id < 100}
    swapped = swap_entry_exit(renamed, truth, ids)
    for track in swapped.objects:
        if track.id >= 100:
            continue
        k = truth.ids.index(track.id)
        assert track.frames.tolist() == np.flatnonzero(truth.visible[:, k]).tolist()
        assert np.all(track.weights > 0)  # the late track's first 10 frames are filled in
    # A gap inside a track stays a gap.
    holed = replace(renamed, objects=tuple(replace(t, weights=np.where(np.arange(len(t.frames)) == 40, 0.0, t.weights)) if t.id == truth.ids[1] else t for t in renamed.objects))
    kept = next(t for t in swap_entry_exit(holed, truth, ids).objects if t.id == truth.ids[1])
    assert kept.weights[np.searchsorted(kept.frames, 40)] == 0.0


def test_true_candidates_are_the_observed_collisions(scene):
    truth, oracle = scene
    assert truth.collisions, "fixture scene 0 has observed collisions"
    candidates = true_candidates(oracle, truth)
    assert sorted((c.bodies[0], c.bodies[1], c.frame) for c in candidates) == sorted(truth.collisions)
    for c in candidates:
        assert np.isclose(np.linalg.norm(c.normal), 1.0)


def test_ungrounded_questions_counts_only_reference_failures():
    """A question counts when its own reference or an undecided option's reference failed to ground; an option
    undecided for another reason (a program that does not apply) does not."""
    from bench.bench_cached_answers import ungrounded_questions
    from planner.answer import Answer, ChoiceAnswer
    from planner.evaluate import QuestionRecord

    def record(error=None, choice_errors=(None,)):
        choices = tuple(ChoiceAnswer(k, "c", None, None if e else "wrong", error=e) for k, e in enumerate(choice_errors))
        return QuestionRecord(0, 0, "explanatory", ("wrong",) * len(choices), Answer("q", "explanatory", None, choices, error=error))

    records = [record(error="cannot ground the question: the red cube: the world has no objects"),
               record(choice_errors=("the green object is ambiguous: objects [5, 7] all match", None)),
               record(choice_errors=("token 7 (unique): unique: expected exactly one item, got 0",)),
               record()]
    assert ungrounded_questions(records) == 2


def test_unknown_rows_are_refused():
    from bench.bench_attribution import main
    with pytest.raises(SystemExit, match="unknown row"):
        main(["/nonexistent", "--rows", "from video,swap colours"])


def test_identification_table_gives_the_records_precision_and_recall():
    fit = {"rmse": 0.01, "observed": [1, 2, 2], "materials": [1, 1], "fit_seconds": 0.1}
    table = identification_table([{"rows": {"from video": {**fit, "record": [3, 4, 5]}}},
                                  {"rows": {"from video": {**fit, "record": [1, 1, 1]}}}])
    assert "| 0.800 / 0.667 (4/5, 4/6) |" in table  # 4 of the 5 recorded collisions are MuJoCo's, 4 of its 6
    assert "| - |" in identification_table([{"rows": {"from video": fit}}])  # a cache from before the column


def test_a_cached_scene_is_refitted_for_the_rows_it_lacks():
    """A cache written with other --rows must not leave the new rows empty (they would score as unanswered)."""
    from bench.bench_attribution import merge_rows, missing_rows
    cached = {"scene": 3, "perceive_seconds": 2.0, "rows": {"from video": {"rmse": 0.01}}}
    assert missing_rows(cached, ["from video", "swap shape", "oracle tracks"]) == ("swap shape", "oracle tracks")
    assert missing_rows(cached, ["from video"]) == ()
    failed = {"scene": 3, "perceive_error": "ValueError: no frames", "rows": {}}
    assert missing_rows(failed, ["from video", "oracle tracks"]) == ("oracle tracks",)
    merged = merge_rows(cached, {"scene": 3, "perceive_seconds": 2.5, "rows": {"swap shape": {"rmse": 0.02}}})
    assert merged["rows"] == {"from video": {"rmse": 0.01}, "swap shape": {"rmse": 0.02}}
    assert merged["perceive_seconds"] == 2.5
