"""A restart with the same data directory keeps every world and rollout; the same ids answer the same."""

from __future__ import annotations

import pytest



def _queries(world_id: str, rollout_ids: list[str]) -> list[tuple[str, str, dict]]:
    calls = [("GET", f"/v1/worlds/{world_id}", {}), ("GET", f"/v1/worlds/{world_id}/rollouts", {}), ("GET", "/v1/worlds", {})]
    for rollout_id in rollout_ids:
        tools = f"/v1/worlds/{world_id}/tools"
        calls += [
            ("POST", f"{tools}/check_contact", {"object_a": 0, "object_b": 1, "rollout_id": rollout_id}),
            ("POST", f"{tools}/inspect_world_state", {"frame": 40, "rollout_id": rollout_id}),
            ("POST", f"{tools}/list_events", {"rollout_id": rollout_id}),
            ("GET", f"/v1/worlds/{world_id}/rollouts/{rollout_id}?detail=full", {}),
        ]
    calls.append(("POST", f"/v1/worlds/{world_id}/tools/compare_rollouts", {"edited_rollout_id": rollout_ids[-1]}))
    return calls


def _answers(process, calls) -> list:
    with process.client() as http:
        out = []
        for method, path, body in calls:
            response = http.request(method, path, json=body if method == "POST" else None)
            assert response.status_code == 200, response.text
            out.append(response.json())
        return out


@pytest.mark.slow
def test_restart_keeps_worlds_and_rollouts(tmp_path, world_document, server_factory):
    data_dir = tmp_path / "data"
    first = server_factory(data_dir, tmp_path / "first.log")
    try:
        with first.client() as http:
            world_id = http.post("/v1/worlds", json={"world": world_document}).json()["world_id"]
            edited = [
                http.post(f"/v1/worlds/{world_id}/tools/simulate_edit", json=args).json()["rollout_id"]
                for args in ({"edit_type": "remove_object", "object_id": 1},
                             {"edit_type": "set_friction", "object_id": 0, "value": 0.02})
            ]
        calls = _queries(world_id, ["base", *edited])
        before = _answers(first, calls)
    finally:
        first.stop()
    assert first.process.returncode is not None

    second = server_factory(data_dir, tmp_path / "second.log")
    try:
        after = _answers(second, calls)
        with second.client() as http:
            listed = [r["rollout_id"] for r in http.get(f"/v1/worlds/{world_id}/rollouts").json()["rollouts"]]
    finally:
        second.stop()
    assert listed == ["base", *edited]
    assert after == before
