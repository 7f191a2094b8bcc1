"""Tool semantics on the six-object world (engine rollouts) and on hand-made rollouts (exact control)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from scene_builders import hand_rollout, two_cube_world
from tools.errors import ToolError
from tools.registry import call_tool
from tools.session import MemoryRolloutStore, WorldSession
from world.rollout import simulate
from world.types import AttributeBelief, Edit, Event


def collision_pairs(rollout) -> dict[tuple[int, int], list[int]]:
    pairs: dict[tuple[int, int], list[int]] = {}
    for e in rollout.events:
        if e.kind == "collision":
            pairs.setdefault(tuple(sorted(e.bodies)), []).append(e.frame)
    return pairs


# --------------------------------------------------------------------------- check_contact / get_event_time
def test_check_contact_reports_every_engine_collision(session):
    base = session.base_rollout()
    pairs = collision_pairs(base)
    assert len(pairs) >= 3, "the fixture world must contain a collision chain"
    for (a, b), frames in pairs.items():
        result = call_tool("check_contact", session, {"object_a": b, "object_b": a})
        assert result["status"] == "collision" and result["evidence"] == "collision_event"
        assert result["matched_frames"] == frames and result["first_frame"] == frames[0]
        assert result["first_event"]["objects"] == [a, b]
        assert result["beyond_video"] == (frames[0] >= base.observed_frames)
        assert result["base_comparison"] is None


def test_nearby_objects_without_contact_are_not_in_contact(session):
    # 0 and 2 never collide in the base rollout; distance alone must not make them touch.
    assert (0, 2) not in collision_pairs(session.base_rollout())
    result = call_tool("check_contact", session, {"object_a": 0, "object_b": 2})
    assert result["status"] == "no_contact" and result["matched_frames"] == []
    assert result["nearest_distance"] > 0


@pytest.mark.parametrize("window", [(0, 5), (8, 30), (0, 2000)])
def test_frame_range_is_inclusive_and_clipped(session, window):
    frames = collision_pairs(session.base_rollout())[(0, 1)]
    start, end = window
    result = call_tool("get_event_time", session, {"object_a": 0, "object_b": 1, "frame_start": start, "frame_end": end})
    expected = [f for f in frames if start <= f <= end]
    assert result["frames"] == expected and result["count"] == len(expected)
    assert result["range"]["frame_end"] == min(end, session.base_rollout().horizon_frames - 1)
    assert result["first_frame"] == (expected[0] if expected else None)


def test_reversed_range_and_same_object_are_rejected(session):
    with pytest.raises(ToolError) as caught:
        call_tool("check_contact", session, {"object_a": 0, "object_b": 1, "frame_start": 9, "frame_end": 3})
    assert caught.value.pointer == "/frame_end"
    with pytest.raises(ToolError) as caught:
        call_tool("check_contact", session, {"object_a": 2, "object_b": 2})
    assert caught.value.pointer == "/object_b"


def _hand_session(base_positions, edited=None, base_events=(), edited_events=()):
    world = two_cube_world()
    store = MemoryRolloutStore()
    store.put_rollout("w", hand_rollout(world, "base", base_positions, base_events), None)
    if edited is not None:
        store.put_rollout("w", hand_rollout(world, "r-edit", edited, edited_events, edits=(Edit("remove_object", 11),)), "base")
    return WorldSession("w", world, store)


def _positions(x_of_cube_9: list[float]) -> np.ndarray:
    """Cube 7 fixed at the origin, cube 9 at x (m) per frame, sphere 11 far away."""
    return np.array([[[0.0, 0.0, 0.2], [x, 0.0, 0.2], [0.0, 3.0, 0.2]] for x in x_of_cube_9])


def test_footprint_scan_finds_sustained_contact_without_events():
    # Cube 9 slides in and rests face to face with cube 7 (gap 0) from frame 3 on; no collision event.
    session = _hand_session(_positions([1.0, 0.8, 0.6, 0.4, 0.4, 0.4, 0.7, 0.7]))
    result = call_tool("check_contact", session, {"object_a": 7, "object_b": 9})
    assert (result["status"], result["evidence"]) == ("contact", "footprint_scan")
    assert result["matched_frames"] == [3, 4, 5] and result["first_frame"] == 3
    events = call_tool("get_event_time", session, {"object_a": 7, "object_b": 9})
    assert events["frames"] == [3] and events["count"] == 1  # one touching run


@pytest.mark.parametrize("gap, tolerance, touching", [(0.0005, 0.001, True), (0.002, 0.001, False), (0.002, 0.005, True)])
def test_scan_tolerance_decides_contact(gap, tolerance, touching):
    session = _hand_session(_positions([0.4 + gap] * 4))
    result = call_tool("check_contact", session, {"object_a": 7, "object_b": 9, "contact_tolerance": tolerance})
    assert result["contact"] is touching
    assert result["nearest_distance"] == pytest.approx(gap, abs=1e-6)


def _collision(frame: int) -> Event:
    return Event("collision", (7, 9), frame / 10.0, frame, (0.2, 0.0, 0.2), 1.0)


@pytest.mark.parametrize(
    "edited_events, change, agrees, delta",
    [
        ((_collision(5),), "unchanged", True, 2),
        ((_collision(1),), "unchanged", True, -2),
        ((_collision(6),), "unchanged", True, 3),  # exactly at the tolerance still agrees
        ((_collision(0),), "unchanged", True, -3),
        ((_collision(7),), "shifted", False, 4),  # tolerance below set to 3 frames
        ((), "removed", False, None),
    ],
)
def test_edited_rollouts_are_compared_with_base_under_a_frame_tolerance(edited_events, change, agrees, delta):
    far = _positions([1.0] * 10)
    session = _hand_session(far, far, base_events=(_collision(3),), edited_events=edited_events)
    result = call_tool("check_contact", session, {"object_a": 7, "object_b": 9, "rollout_id": "r-edit", "frame_tolerance": 3})
    comparison = result["base_comparison"]
    assert (comparison["change"], comparison["agrees_with_base"], comparison["frame_delta"]) == (change, agrees, delta)
    assert comparison["base_first_frame"] == 3 and comparison["base_status"] == "collision"


def test_contact_added_by_an_edit():
    far = _positions([1.0] * 10)
    session = _hand_session(far, far, edited_events=(_collision(6),))
    comparison = call_tool("check_contact", session, {"object_a": 7, "object_b": 9, "rollout_id": "r-edit"})["base_comparison"]
    assert comparison["change"] == "added" and comparison["base_status"] == "no_contact"


def test_beyond_video_flag_uses_observed_frames():
    far = _positions([1.0] * 12)  # observed_frames = 8
    session = _hand_session(far, base_events=(_collision(10),))
    result = call_tool("check_contact", session, {"object_a": 7, "object_b": 9})
    assert result["beyond_video"] is True and result["first_event"]["beyond_video"] is True


# --------------------------------------------------------------------------- inspection
def test_world_state_matches_rollout_arrays(session):
    base = session.base_rollout()
    frame = collision_pairs(base)[(2, 3)][0]
    result = call_tool("inspect_world_state", session, {"frame": frame})
    assert result["status"] == "ok"
    active_ids = [b for k, b in enumerate(base.body_ids) if base.active[frame, k]]
    assert [o["object_id"] for o in result["objects"]] == active_ids
    for record in result["objects"]:
        k = base.body_ids.index(record["object_id"])
        np.testing.assert_allclose(record["position"], base.positions[frame, k], atol=1e-6)
    assert [c["objects"] for c in result["collisions"]] == [[2, 3]]


def test_world_state_omits_objects_not_yet_entered(session, world):
    late = [b for b in world.bodies if b.initial.time > 0][0]
    before_entry = int(round(late.initial.time * world.fps)) - 1
    result = call_tool("inspect_world_state", session, {"frame": before_entry})
    assert late.id not in [o["object_id"] for o in result["objects"]]


@pytest.mark.parametrize("offset", [0, 1, 500])
def test_frames_outside_the_rollout_are_missing_not_interpolated(session, offset):
    horizon = session.base_rollout().horizon_frames
    result = call_tool("inspect_world_state", session, {"frame": horizon + offset})
    assert result["status"] == "missing_frame" and result["objects"] == [] and result["time"] is None


@pytest.mark.parametrize("start, end, stride", [(None, None, 1), (10, 20, 1), (0, 40, 7), (150, 9999, 1)])
def test_object_trajectory_records(session, start, end, stride):
    args = {"object_id": 0, "stride": stride}
    if start is not None:
        args.update(frame_start=start, frame_end=end)
    result = call_tool("inspect_object_trajectory", session, args)
    base = session.base_rollout()
    lo = start or 0
    hi = base.horizon_frames - 1 if end is None else min(end, base.horizon_frames - 1)
    expected_frames = list(range(lo, hi + 1))[::stride]
    assert [r["frame"] for r in result["records"]] == expected_frames
    assert result["count"] == len(expected_frames)
    assert result["first"] == result["records"][0] and result["last"] == result["records"][-1]


def test_trajectory_skips_frames_before_entry(session, world):
    late = [b for b in world.bodies if b.initial.time > 0][0]
    result = call_tool("inspect_object_trajectory", session, {"object_id": late.id})
    assert result["first"]["frame"] == int(round(late.initial.time * world.fps))


@pytest.mark.parametrize("filters", [{}, {"kinds": ["collision"]}, {"kinds": ["in", "out"]}, {"object_id": 3}, {"frame_start": 15, "frame_end": 60}])
def test_list_events_filters(session, filters):
    base = session.base_rollout()
    kinds = set(filters.get("kinds", ["collision", "in", "out", "stop"]))
    expected = [e for e in base.events if e.kind in kinds
                and filters.get("frame_start", 0) <= e.frame <= filters.get("frame_end", 10**9)
                and ("object_id" not in filters or filters["object_id"] in e.bodies)]
    result = call_tool("list_events", session, filters)
    assert [(e["kind"], e["objects"], e["frame"]) for e in result["events"]] == [(e.kind, list(e.bodies), e.frame) for e in expected]
    assert result["count"] == len(expected)


def test_world_summary_grounds_objects(session, world):
    result = call_tool("get_world_summary", session, {})
    assert [o["object_id"] for o in result["objects"]] == list(world.body_ids)
    assert [(o["shape"], o["color"], o["material"]) for o in result["objects"]] == [
        (b.shape.kind, b.color, b.material) for b in world.bodies]
    assert result["fit_error"] == dict(world.provenance["fit_error"])
    assert result["rollout_ids"] == ["base"]


# --------------------------------------------------------------------------- simulate_edit / remove_object / compare
def test_remove_object_replays_like_the_engine(session, world):
    result = call_tool("simulate_edit", session, {"edit_type": "remove_object", "object_id": 1})
    direct = simulate(world, [Edit("remove_object", 1)])
    assert [(c["objects"], c["frame"]) for c in result["collisions"]] == [
        (list(e.bodies), e.frame) for e in direct.events if e.kind == "collision"]
    assert result["rollout_id"] in session.rollout_ids() and result["rollout_id"] != "base"
    removed = [o for o in result["trajectories"]["objects"] if o["removed"]]
    assert [o["object_id"] for o in removed] == [1] and removed[0]["active_frames"] is None
    assert result["edit_manifest"]["edits"] == [result["edit_manifest"]["applied"]]
    assert result["fit_error"] == dict(world.provenance["fit_error"])
    # The new id answers other tools, and the removed object no longer touches anything.
    check = call_tool("check_contact", session, {"object_a": 0, "object_b": 1, "rollout_id": result["rollout_id"]})
    assert check["status"] == "no_contact" and check["base_comparison"]["change"] == "removed"


def test_legacy_remove_object_equals_simulate_edit(session):
    legacy = call_tool("remove_object", session, {"object_id": 2})
    general = call_tool("simulate_edit", session, {"edit_type": "remove_object", "object_id": 2})
    assert legacy["rollout_id"] != general["rollout_id"]
    for key in ("collisions", "in_out_events", "boundaries", "trajectories"):
        assert legacy[key] == general[key]


@pytest.mark.parametrize("detail, every", [("summary", 25), ("sampled", 10), ("full", 1)])
def test_trajectory_detail_controls_response_size(session, detail, every):
    result = call_tool("simulate_edit", session, {"edit_type": "remove_object", "object_id": 5,
                                                  "trajectory_detail": detail, "sample_every": every})
    object0 = result["trajectories"]["objects"][0]
    if detail == "summary":
        assert "samples" not in object0
    else:
        frames = [s["frame"] for s in object0["samples"]]
        first, last = object0["active_frames"]["first"], object0["active_frames"]["last"]
        assert frames[0] == first and frames[-1] == last
        assert len(frames) == (last - first + 1 if detail == "full" else len(range(first, last + 1, every)) + ((last - first) % every != 0))


def test_edits_stack_on_based_on(session, world):
    first = call_tool("simulate_edit", session, {"edit_type": "set_friction", "object_id": 0, "value": 0.05})
    second = call_tool("simulate_edit", session, {"edit_type": "remove_object", "object_id": 3, "based_on": first["rollout_id"]})
    assert [e["edit_type"] for e in second["edit_manifest"]["edits"]] == ["set_friction", "remove_object"]
    direct = simulate(world, [Edit("set_friction", 0, 0.05), Edit("remove_object", 3)])
    assert [c["frame"] for c in second["collisions"]] == [e.frame for e in direct.events if e.kind == "collision"]


@pytest.mark.parametrize(
    "args, pointer",
    [
        ({"edit_type": "remove_object", "object_id": 1, "value": 2}, "/value"),
        ({"edit_type": "set_mass", "object_id": 1, "value": -1}, "/value"),
        ({"edit_type": "set_mass", "object_id": 1}, "/value"),
        ({"edit_type": "set_velocity", "object_id": 1, "value": 2.0}, "/value"),
        ({"edit_type": "set_restitution", "object_id": 1, "value": 1.5}, "/value"),
        ({"edit_type": "set_restitution", "object_id": 1, "value": 0.5, "other_object_id": 1}, "/other_object_id"),
        ({"edit_type": "set_friction", "object_id": 1, "value": 0.5, "other_object_id": 2}, "/other_object_id"),
    ],
)
def test_inconsistent_edits_are_rejected_with_a_pointer(session, args, pointer):
    with pytest.raises(ToolError) as caught:
        call_tool("simulate_edit", session, args)
    assert caught.value.status == 422 and caught.value.pointer == pointer


@pytest.mark.parametrize(
    "tool, args, code, pointer",
    [
        ("simulate_edit", {"edit_type": "remove_object", "object_id": 42}, "object_not_found", "/object_id"),
        ("simulate_edit", {"edit_type": "remove_object", "object_id": 1, "based_on": "r-missing"}, "rollout_not_found", "/based_on"),
        ("inspect_world_state", {"frame": 3, "rollout_id": "r-missing"}, "rollout_not_found", "/rollout_id"),
        ("inspect_object_trajectory", {"object_id": 99}, "object_not_found", "/object_id"),
        ("compare_rollouts", {}, "rollout_not_found", "/edited_rollout_id"),
        ("compare_rollouts", {"edited_rollout_id": "base", "object_ids": [0, 77]}, "object_not_found", "/object_ids/1"),
        ("list_events", {"object_id": 64}, "object_not_found", "/object_id"),
    ],
)
def test_unknown_ids_are_404_with_valid_ids(session, world, tool, args, code, pointer):
    with pytest.raises(ToolError) as caught:
        call_tool(tool, session, args)
    error = caught.value
    assert (error.status, error.code, error.pointer) == (404, code, pointer)
    valid = list(world.body_ids) if code == "object_not_found" else session.rollout_ids()
    assert list(error.valid_ids) == valid


def test_horizon_limit_is_enforced(world):
    session = WorldSession("w", world, MemoryRolloutStore(), max_horizon_frames=300)
    with pytest.raises(ToolError) as caught:
        call_tool("simulate_edit", session, {"edit_type": "remove_object", "object_id": 1, "horizon_frames": 301})
    assert (caught.value.code, caught.value.pointer) == ("limit_exceeded", "/horizon_frames")
    longer = call_tool("simulate_edit", session, {"edit_type": "remove_object", "object_id": 1, "horizon_frames": 300})
    assert longer["boundaries"]["horizon_frames"] == 300


def test_compare_rollouts_pairs_and_displacements(session, world):
    edited = call_tool("simulate_edit", session, {"edit_type": "remove_object", "object_id": 1})
    result = call_tool("compare_rollouts", session, {})  # defaults: base vs the latest edited rollout
    assert result["edited_rollout_id"] == edited["rollout_id"]
    base_pairs = set(collision_pairs(session.base_rollout()))
    edit_pairs = set(collision_pairs(simulate(world, [Edit("remove_object", 1)])))
    assert {tuple(p) for p in result["added_pairs"]} == edit_pairs - base_pairs
    assert {tuple(p) for p in result["removed_pairs"]} == base_pairs - edit_pairs
    by_id = {d["object_id"]: d for d in result["trajectory_differences"]}
    assert by_id[1]["present_in_edited"] is False and by_id[1]["samples"] == 0
    assert by_id[5]["max_displacement"] == pytest.approx(0.0, abs=1e-9)  # untouched by the chain
    assert by_id[2]["max_displacement"] > 0.01  # pushed differently without 1 in between
    restricted = call_tool("compare_rollouts", session, {"object_ids": [5]})
    assert [d["object_id"] for d in restricted["trajectory_differences"]] == [5]
    assert restricted["reference_collisions"] == [] and restricted["edited_collisions"] == []


def test_comparing_a_rollout_with_itself_shows_no_change(session):
    result = call_tool("compare_rollouts", session, {"edited_rollout_id": "base"})
    assert result["added_pairs"] == [] and result["removed_pairs"] == []
    assert all(d["max_displacement"] in (0.0, None) for d in result["trajectory_differences"])


def test_base_rollout_is_computed_once(world):
    store = MemoryRolloutStore()
    session = WorldSession("w", world, store)
    for _ in range(3):
        call_tool("inspect_world_state", session, {"frame": 0})
    assert store.rollout_ids("w") == ["base"]
    assert session.base_rollout() is session.base_rollout()


@pytest.mark.parametrize(
    "provenance, expected",
    [
        ({}, None),
        ({"fit": {"rmse": 0.02, "seconds": 1.5, "stages": [1, 2],
                  "objects": [{"id": 0, "rmse": 0.01, "observed_frames": 128, "flags": []}, {"id": "x"}]}},
         {"rmse": 0.02, "seconds": 1.5, "objects": [{"object_id": 0, "rmse": 0.01, "observed_frames": 128}]}),
        ({"rmse": 0.5}, {"rmse": 0.5}),
        ({"fit": 0.25}, {"rmse": 0.25}),
        ({"fit": "garbage", "notes": [1, 2]}, None),
    ],
)
def test_fit_error_from_provenance(world, provenance, expected):
    session = WorldSession("w", dataclasses.replace(world, provenance=provenance), MemoryRolloutStore())
    assert call_tool("get_world_summary", session, {})["fit_error"] == expected


def test_removal_from_a_later_start_frame_keeps_the_earlier_past(session):
    base_pairs = collision_pairs(session.base_rollout())
    early, late = base_pairs[(2, 3)][0], base_pairs[(3, 4)][0]
    start = (early + late) // 2
    result = call_tool("simulate_edit", session, {"edit_type": "remove_object", "object_id": 3, "start_frame": start})
    pairs = {tuple(c["objects"]) for c in result["collisions"]}
    assert (2, 3) in pairs and (3, 4) not in pairs
    cube = [o for o in result["trajectories"]["objects"] if o["object_id"] == 3][0]
    assert cube["active_frames"]["last"] == start - 1
    assert result["edit_manifest"]["applied"]["start_frame"] == start


# --------------------------------------------------------------------------- continue_world
def test_continue_world_is_the_unedited_world_to_a_longer_horizon(session, world):
    from world.rollout import default_horizon

    horizon = default_horizon(world) + 40
    first = call_tool("continue_world", session, {"horizon_frames": horizon})
    again = call_tool("continue_world", session, {"horizon_frames": horizon})
    assert first["rollout_id"] == again["rollout_id"] != "base"
    direct = simulate(world, horizon_frames=horizon)
    assert [(c["objects"], c["frame"]) for c in first["collisions"]] == [
        (list(e.bodies), e.frame) for e in direct.events if e.kind == "collision"]
    assert first["boundaries"]["horizon_frames"] == horizon
    assert session.rollout(first["rollout_id"], tool=None).edits == ()


def test_world_summary_reports_attribute_beliefs_only_where_the_world_has_them(world):
    belief = AttributeBelief.from_mappings({"green": 0.6, "cyan": 0.4}, {"metal": 0.2, "rubber": 0.8},
                                           {"cube": 0.5, "cylinder": 0.3, "sphere": 0.2}, support_frames=40)
    perceived = dataclasses.replace(world, bodies=(dataclasses.replace(world.bodies[0], attribute_belief=belief), *world.bodies[1:]))
    objects = call_tool("get_world_summary", WorldSession("w-belief", perceived, MemoryRolloutStore()), {})["objects"]
    assert objects[0]["attribute_belief"] == {"color": {"green": 0.6, "cyan": 0.4}, "material": {"metal": 0.2, "rubber": 0.8},
                                              "shape": {"cube": 0.5, "cylinder": 0.3, "sphere": 0.2}, "support_frames": 40}
    assert all("attribute_belief" not in o for o in objects[1:])


def test_world_summary_reports_contact_friction_only_where_the_world_has_it(world):
    """The friction between bodies a fitted world carries is visible to the agent (call_tool validates the result schema)."""
    fitted = dataclasses.replace(world, bodies=(dataclasses.replace(world.bodies[0], contact_friction=0.35), *world.bodies[1:]))
    objects = call_tool("get_world_summary", WorldSession("w-contact", fitted, MemoryRolloutStore()), {})["objects"]
    assert objects[0]["contact_friction"] == 0.35
    assert all("contact_friction" not in o for o in objects[1:])
