"""The Physion generator, the curtain round trip, known-property labels and `physmind eval` on the layout."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from synth.physion.categories import sample_trial
from synth.physion.mujoco_run import run_trial
from synth.physion.generate import generate_trial, write_trials
from physmind.physion_eval import world_cache_path
from synth.physion.spec import CATEGORIES, FPS, world_from_spec
from synth.render import read_mp4
from world.scene3d.identify import identify_properties
from world.scene3d.io import tracks_from_annotation, validate_physion, world3d_from_dict, world3d_to_dict
from world.scene3d.predict import answer_contact
from world.scene3d.rollout import predict_contact
from world.scene3d.types import State3D

SEED = 11  # tests only; the benchmark uses 2026


@pytest.fixture(scope="module")
def wall_trial(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("physion_wall")
    entry, _ = generate_trial(out, SEED, "bounce_wall", 0, 1)
    write_trials(out, [entry])
    return out


def test_layout_files_and_curtain(wall_trial: Path):
    trials = json.loads((wall_trial / "trials.json").read_text())
    validate_physion(trials, "trials")
    index = trials[0]["index"]
    annotation = json.loads((wall_trial / "annotations" / f"annotation_{index:05d}.json").read_text())
    validate_physion(annotation, "annotation")
    first, last = annotation["curtain_frames"]
    frames = {f["frame_id"]: f["objects"] for f in annotation["motion_trajectory"]}
    assert all(frames[f] == [] for f in range(first, last + 1))
    assert frames[first - 1] and frames[last + 1]
    assert [p["frames"] for p in annotation["phases"]] == [[0, first - 1], [last + 1, annotation["prediction_boundary_frame"]]]
    assert annotation["patient_zone"] in [b["id"] for b in annotation["phases"][1]["static_objects"] if b["role"] == "zone"]
    video = read_mp4(wall_trial / "videos" / trials[0]["video_filename"])
    assert len(video) == annotation["prediction_boundary_frame"] + 1
    curtain = video[first:last + 1].reshape(last - first + 1, -1, 3).astype(int)
    assert np.abs(curtain - np.median(curtain, axis=1, keepdims=True)).max() <= 3  # one flat colour hides everything
    assert video[first - 1].reshape(-1, 3).std(axis=0).max() > 5.0


def test_curtain_round_trip_carries_the_fitted_restitution(wall_trial: Path):
    index = json.loads((wall_trial / "trials.json").read_text())[0]["index"]
    annotation = json.loads((wall_trial / "annotations" / f"annotation_{index:05d}.json").read_text())
    truth = json.loads((wall_trial / "ground_truth" / f"trial_{index:05d}.json").read_text())
    tracks, timing, states = tracks_from_annotation(annotation)
    before_curtain = identify_properties(tracks, phases=(0,)).get("restitution", 0)
    curtain_time = annotation["curtain_frames"][0] / FPS
    seen = [i["restitution"] for i in truth["realised_restitution"]["impacts"] if i["time"] < curtain_time]
    realised = float(np.median(seen))  # what MuJoCo's soft contact did at the impacts the video shows
    assert before_curtain is not None and abs(before_curtain.value - realised) < 0.1 * realised
    answer = answer_contact(tracks, timing, states)
    world = world3d_from_dict(json.loads(json.dumps(world3d_to_dict(answer.world))))
    assert world == answer.world  # lossless through JSON and the schema
    assert len(world.phases) == 2 and world.phases[1].start_time == pytest.approx(timing.phase_frames[1][0] / FPS)
    assert world.body(0).restitution == pytest.approx(answer.report.get("restitution", 0).value)
    assert answer.contact == truth["label"]


def engine_answer(trial, runs) -> bool:
    """The engine's answer with the trial's true property, continued from MuJoCo's state at the boundary.

    MuJoCo's soft contact realises a restitution near, not at, its parameter: a restitution trial uses
    the median e MuJoCo realised at the agent's impacts.
    """
    if trial.property_kind == "restitution":
        trial = trial.with_property(float(np.median([e for r in runs for _, e in r.impacts])))
    run = runs[-1]
    row = int(np.nonzero(run.frame_ids == trial.boundary_frame)[0][0])
    states = {i: State3D(run.positions[row, n], run.velocities[row, n]) for n, i in enumerate(run.body_ids)}
    contact, _, _ = predict_contact(world_from_spec(trial), trial.horizon_frame / FPS,
                                    start_time=trial.boundary_frame / FPS, states=states)
    return contact


@pytest.mark.parametrize("category", CATEGORIES)
def test_label_of_a_trial_with_a_known_property(category):
    k = 1  # an odd k wants label false, so the label comes from the property, not the placement alone
    sampled = sample_trial(category, np.random.default_rng([SEED, CATEGORIES.index(category), k]), k, want_label=False)
    assert engine_answer(sampled.trial, sampled.runs) == sampled.label
    swapped = sampled.trial.with_property(sampled.trial.swapped_value)
    assert engine_answer(swapped, run_trial(swapped)) == sampled.swapped_label


@pytest.fixture(scope="module")
def eval_layout(tmp_path_factory) -> Path:
    """One trial per category, without video (the eval reads the oracle tracks)."""
    out = tmp_path_factory.mktemp("physion_eval")
    write_trials(out, [generate_trial(out, SEED + 1, category, 0, 1, video=False)[0] for category in CATEGORIES])
    return out


@pytest.mark.slow
def test_physmind_eval_answers_through_the_tools(eval_layout: Path, tmp_path: Path, capsys):
    from physmind.cli import main

    entries = json.loads((eval_layout / "trials.json").read_text())
    report_path, cache = tmp_path / "report.json", tmp_path / "worlds"
    assert main(["eval", str(eval_layout), "-o", str(report_path), "--workers", "2", "--cache", str(cache)]) == 0
    printed = capsys.readouterr().out
    assert "Fric. Plat." in printed and "Bounce Wall" in printed and "Overall" in printed
    report = json.loads(report_path.read_text())
    assert [r["index"] for r in report["trials"]] == [e["index"] for e in entries]
    for record, entry in zip(report["trials"], entries):
        assert record["category"] == entry["category"] and record["label"] == entry["label"]
        assert [c["tool"] for c in record["tool_calls"]] == ["get_world_summary", "continue_world", "check_contact"]
        validate_physion(record["world"], "world3d")
        # the tools give the answer the engine's own contact query gives on the same fitted world
        annotation = json.loads((eval_layout / "annotations" / f"annotation_{entry['index']:05d}.json").read_text())
        direct = answer_contact(*tracks_from_annotation(annotation))
        assert record["prediction"] == direct.contact
        if direct.contact:
            assert record["contact_time"] == pytest.approx(direct.time, abs=1e-6)
            assert f"contact at t = {direct.time:.3f} s" in record["evidence"]
        else:
            assert "closest approach" in record["evidence"]
        property_kind = {"mass_collision": "mass_ratio", "friction_collision": "friction", "friction_platform": "friction",
                         "bounce_platform": "restitution", "bounce_wall": "restitution"}[entry["category"]]
        assert f"{property_kind} of object" in record["evidence"]
        assert world_cache_path(cache, entry["index"]).is_file()
    assert report["accuracy"]["overall"] == pytest.approx(
        100.0 * sum(r["prediction"] == r["label"] for r in report["trials"]) / len(entries), abs=0.01)
    # a second run reuses the cached worlds and answers the same
    assert main(["eval", str(eval_layout), "-o", str(tmp_path / "again.json"), "--cache", str(cache)]) == 0
    again = json.loads((tmp_path / "again.json").read_text())
    assert [r["prediction"] for r in again["trials"]] == [r["prediction"] for r in report["trials"]]


@pytest.mark.slow
def test_physmind_eval_uses_a_given_server(eval_layout: Path, tmp_path: Path):
    from physmind.cli import main
    from physmind.local_server import local_server

    with local_server() as url:
        assert main(["eval", str(eval_layout), "-o", str(tmp_path / "r.json"), "--limit", "1", "--server", url]) == 0
    report = json.loads((tmp_path / "r.json").read_text())
    assert report["server"] == url and report["trials"][0]["error"] is None


@pytest.mark.parametrize("flags, message", [(["--mode", "trajectory_only"], "--mode trajectory_only"),
                                            (["--camera", "camera.json"], "--camera"),
                                            (["--workers", "0"], "--workers"),
                                            (["--source", "video"], "--source video")])
def test_physmind_eval_rejects_flags_it_cannot_honour(eval_layout: Path, tmp_path: Path, capsys, flags, message):
    from physmind.cli import main

    assert main(["eval", str(eval_layout), "-o", str(tmp_path / "r.json"), *flags]) == 2
    error = capsys.readouterr().err.strip()
    assert message in error and len(error.splitlines()) == 1 and "Traceback" not in error


def test_contact_question_is_parsed():
    from physmind.physion_eval import parse_contact_question

    assert parse_contact_question("Will the red object contact the yellow object?") == ("agent", "patient")
    assert parse_contact_question("will the red one touch the yellow zone") == ("agent", "patient")
    with pytest.raises(ValueError, match="only the red agent"):
        parse_contact_question("Will the blue object contact the yellow object?")
    with pytest.raises(ValueError, match="not a contact question"):
        parse_contact_question("What color is the cube?")


@pytest.mark.parametrize("category, kind, tolerance", [("friction_collision", "friction", 0.10),
                                                        ("friction_platform", "friction", 0.10),
                                                        ("mass_collision", "mass_ratio", 0.20)])
def test_identified_property_against_mujoco(category, kind, tolerance):
    from synth.physion.generate import annotation_document

    k = 2
    sampled = sample_trial(category, np.random.default_rng([SEED, CATEGORIES.index(category), k]), k, want_label=True)
    tracks, _, _ = tracks_from_annotation(json.loads(json.dumps(annotation_document(sampled))))
    first_phase = (0,)  # before the curtain (or the whole observed phase without one)
    if kind == "mass_ratio":
        estimate = identify_properties(tracks, first_phase).get("mass_ratio", 0)
        truth = next(b.mass for b in sampled.trial.bodies if b.id == estimate.other_id)
    else:
        estimate = identify_properties(tracks, first_phase).get(kind, sampled.trial.property_body)
        truth = sampled.trial.property_value
    assert estimate is not None and abs(estimate.value - truth) <= tolerance * truth
    assert estimate.std < 0.05 * truth  # the stated uncertainty is small on clean tracks
