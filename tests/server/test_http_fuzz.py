"""Property-based fuzzing of the running server from its own OpenAPI spec (schemathesis): no 5xx, ever.

Each operation gets positive (schema-valid) and negative (schema-violating)
requests; tool operations run against a real world most of the time so the
tools themselves are exercised, not only the 404 path. Bounded in examples
and wall time; loopback only.
"""

from __future__ import annotations

import json
import time

import pytest
import schemathesis
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.errors import Unsatisfiable
from schemathesis import GenerationMode

from tools.registry import get_tool, validate_result

EXAMPLES_PER_OPERATION = 25
CONTRACT_CHECKS = [schemathesis.checks.not_a_server_error, schemathesis.checks.status_code_conformance,
                   schemathesis.checks.content_type_conformance, schemathesis.checks.response_schema_conformance,
                   schemathesis.checks.response_headers_conformance, schemathesis.checks.allow_header_conformance]
TIME_BUDGET_S = 60.0


def _check(response, operation_label: str) -> None:
    assert response.status_code < 500, f"{operation_label}: {response.status_code} {response.text[:500]}"
    if response.status_code >= 400:
        error = response.json()["error"]
        assert {"code", "pointer", "message"} <= set(error), response.text
        assert "Traceback" not in response.text


@pytest.mark.slow
def test_fuzz_api_from_openapi(server, world_document):
    with server.client() as http:
        world_id = http.post("/v1/worlds", json={"world": world_document, "name": "fuzz"}).json()["world_id"]
        http.post(f"/v1/worlds/{world_id}/tools/simulate_edit", json={"edit_type": "remove_object", "object_id": 2})
    schema = schemathesis.openapi.from_url(server.url + "/openapi.json")
    deadline = time.monotonic() + TIME_BUDGET_S
    operations = [result.ok() for result in schema.get_all_operations()]
    assert len(operations) >= 16
    calls = {"count": 0, "tool_ok": 0}
    for operation in operations:
        label = f"{operation.method.upper()} {operation.path}"
        uses_world = "{world_id}" in operation.path and operation.method.lower() != "delete"
        tool_name = operation.path.rsplit("/", 1)[-1] if "/tools/" in operation.path and "{world_id}" in operation.path else None
        for mode in (GenerationMode.POSITIVE, GenerationMode.NEGATIVE):
            if time.monotonic() > deadline:
                break
            fixed = {"world_id": world_id} if uses_world else None
            try:
                strategy = operation.as_strategy(generation_mode=mode, path_parameters=fixed)
            except Exception:  # an operation without a negative variant
                continue

            @settings(max_examples=EXAMPLES_PER_OPERATION, deadline=None, database=None, derandomize=True,
                      suppress_health_check=list(HealthCheck))
            @given(case=strategy, real_world=st.booleans())
            def run(case, real_world):
                if time.monotonic() > deadline:
                    return
                if uses_world and not real_world:
                    case.path_parameters["world_id"] = "w-unknown"
                response = case.call(base_url=server.url, timeout=60)
                calls["count"] += 1
                _check(response, label)
                # The published contract: declared status codes, response schemas (errors too), headers, Allow.
                case.validate_response(response, checks=CONTRACT_CHECKS)
                if tool_name and response.status_code == 200:
                    calls["tool_ok"] += 1
                    validate_result(get_tool(tool_name), response.json())

            try:
                run()
            except Unsatisfiable:
                # Nothing to violate (e.g. GET /healthz has no parameters): only positive cases exist.
                assert mode is GenerationMode.NEGATIVE, label
    print(f"fuzz: {calls['count']} requests, {calls['tool_ok']} successful tool calls")
    assert calls["count"] > 100
    statuses = [json.loads(line).get("status", 0) for line in server.log_lines() if line.startswith('{"ts"')]
    assert statuses and max(statuses) < 500
    assert calls["tool_ok"] > 10  # the tools really ran on valid generated arguments
