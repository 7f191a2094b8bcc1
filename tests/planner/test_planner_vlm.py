"""The VLM function-calling loop end to end, against a scripted chat-completions server on loopback.

No model can be reached here. The scripted server speaks the OpenAI chat-completions
protocol and plays a fixed script of tool calls; its steps read the tool results the
client sends back (so the final verdicts depend on what the world tools really
returned) and every request is recorded for the assertions.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any, Callable

import jsonschema
import pytest

from planner.vlm import SUBMIT_TOOL, ChatClient, VlmConfig, VlmError, answer_schema, answer_with_vlm
from world.rollout import simulate
from world.types import Edit

COLOR = {0: "red", 1: "blue", 2: "green", 3: "yellow", 4: "purple", 5: "gray"}
Step = Callable[[dict], dict]


class ScriptedChat:
    """A chat-completions endpoint that answers request k with ``script[k](request)``."""

    def __init__(self, script: list[Step], status: int = 200):
        self.script = script
        self.status = status
        self.requests: list[dict] = []
        self.headers: list[dict] = []
        chat = self

        class Handler(BaseHTTPRequestHandler):
            def do_POST(self) -> None:  # noqa: N802 (http.server API)
                body = json.loads(self.rfile.read(int(self.headers["Content-Length"])))
                chat.requests.append(body)
                chat.headers.append(dict(self.headers))
                if self.path != "/v1/chat/completions" or chat.status != 200:
                    payload, status = {"error": {"message": "scripted failure"}}, chat.status if chat.status != 200 else 404
                else:
                    step = chat.script[min(len(chat.requests) - 1, len(chat.script) - 1)]
                    message = step(body)
                    payload = {"id": f"chatcmpl-{len(chat.requests)}", "object": "chat.completion", "model": body["model"],
                               "choices": [{"index": 0, "message": {"role": "assistant", **message},
                                            "finish_reason": "tool_calls" if message.get("tool_calls") else "stop"}],
                               "usage": {"prompt_tokens": 10, "completion_tokens": 5, "total_tokens": 15}}
                    status = 200
                data = json.dumps(payload).encode()
                self.send_response(status)
                self.send_header("Content-Type", "application/json")
                self.send_header("Content-Length", str(len(data)))
                self.end_headers()
                self.wfile.write(data)

            def log_message(self, *args: Any) -> None:
                pass

        self.server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.url = f"http://127.0.0.1:{self.server.server_address[1]}/v1"
        self.thread = threading.Thread(target=self.server.serve_forever, daemon=True)

    def __enter__(self) -> "ScriptedChat":
        self.thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.server.shutdown()
        self.server.server_close()


def tool_call(call_id: str, name: str, arguments: Any) -> dict:
    text = arguments if isinstance(arguments, str) else json.dumps(arguments)
    return {"id": call_id, "type": "function", "function": {"name": name, "arguments": text}}


def tool_results(request: dict) -> dict[str, Any]:
    """tool_call_id -> parsed content of the tool messages in a request."""
    return {m["tool_call_id"]: json.loads(m["content"]) if m["content"].startswith("{") else m["content"]
            for m in request["messages"] if m["role"] == "tool"}


def summary_in(request: dict) -> dict:
    user = next(m["content"] for m in request["messages"] if m["role"] == "user")
    return json.loads(user.split("World summary (get_world_summary):\n", 1)[1])


PAIRS = [(0, 2), (2, 3), (3, 4), (0, 1)]
QUESTION = "Which of the following will happen if the blue object is removed?"
CHOICES = [f"The {COLOR[a]} object collides with the {COLOR[b]} object" for a, b in PAIRS]


def removal_script() -> list[Step]:
    """Ground "blue" in the summary, remove it, compare rollouts, then judge each pair from the replay's collisions."""

    def remove_blue(request: dict) -> dict:
        blue = next(o["object_id"] for o in summary_in(request)["objects"] if o["color"] == "blue")
        return {"content": None, "tool_calls": [tool_call("c1", "simulate_edit", {"edit_type": "remove_object", "object_id": blue,
                                                                                   "trajectory_detail": "summary"})]}

    def compare(request: dict) -> dict:
        edited = tool_results(request)["c1"]
        return {"content": None, "tool_calls": [tool_call("c2", "compare_rollouts", {"edited_rollout_id": edited["rollout_id"]})]}

    def submit(request: dict) -> dict:
        results = tool_results(request)
        observed = results["c1"]["boundaries"]["observed_frames"]
        seen = {tuple(c["objects"]) for c in results["c1"]["collisions"] if c["frame"] < observed}
        answers = [{"choice_id": k, "verdict": "correct" if pair in seen else "wrong",
                    "reason": f"pair {pair} {'collides' if pair in seen else 'does not collide'} in {results['c2']['edited_rollout_id']}"}
                   for k, pair in enumerate(PAIRS)]
        return {"content": None, "tool_calls": [tool_call("c3", SUBMIT_TOOL, {"answers": answers})]}

    return [remove_blue, compare, submit]


@pytest.fixture()
def world(tool_client, six_document):
    return tool_client.create_world(six_document)


def test_tool_calling_loop_end_to_end(tool_client, world, six_world):
    with ScriptedChat(removal_script()) as chat:
        config = VlmConfig(base_url=chat.url, model="scripted", api_key="test-key")
        with ChatClient(config) as client:
            answer = answer_with_vlm(client, tool_client, world, QUESTION, CHOICES, config)
    replay = simulate(six_world, [Edit("remove_object", 1)])
    expected = {tuple(sorted(e.bodies)) for e in replay.events if e.kind == "collision" and e.frame < 128}
    assert answer.verdicts == ["correct" if p in expected else "wrong" for p in PAIRS]
    assert answer.method == "vlm" and answer.verdicts[0] == "correct"  # (0, 2) only happens in the replay
    # The model's calls were executed on the world and are cited as evidence.
    cited = [world.calls[i].tool for i in answer.tool_calls]
    assert cited == ["get_world_summary", "simulate_edit", "compare_rollouts"]
    assert all(c.facts and c.facts[0].startswith("model: pair") for c in answer.choices)
    assert answer.extra["chat_requests"] == 3 and answer.extra["usage"]["total_tokens"] == 45
    # Protocol: the server's tool list is offered unchanged plus submit_answer; tool results go back by id.
    first = chat.requests[0]
    names = [t["function"]["name"] for t in first["tools"]]
    assert names[-1] == SUBMIT_TOOL and {"simulate_edit", "check_contact", "compare_rollouts", "get_world_summary"} <= set(names)
    served = tool_client.tools()
    assert first["tools"][:-1] == served
    assert first["model"] == "scripted" and first["tool_choice"] == "auto"
    assert QUESTION in first["messages"][1]["content"] and all(c in first["messages"][1]["content"] for c in CHOICES)
    assert [m["role"] for m in chat.requests[2]["messages"]] == ["system", "user", "assistant", "tool", "assistant", "tool"]
    assert chat.requests[1]["messages"][2]["tool_calls"][0]["id"] == "c1"
    assert all(h.get("Authorization") == "Bearer test-key" for h in chat.headers)


def test_tool_call_budget_forces_an_answer(tool_client, world):
    def probe(request: dict) -> dict:
        if [t["function"]["name"] for t in request["tools"]] == [SUBMIT_TOOL]:
            answers = [{"choice_id": k, "verdict": "wrong", "reason": "budget spent"} for k in range(2)]
            return {"content": None, "tool_calls": [tool_call("final", SUBMIT_TOOL, {"answers": answers})]}
        k = len(request["messages"])  # two parallel calls per turn: the budget must stop the second one of turn 2
        return {"content": None, "tool_calls": [tool_call(f"p{k}a", "get_event_time", {"object_a": 0, "object_b": 1}),
                                                tool_call(f"p{k}b", "get_event_time", {"object_a": 1, "object_b": 2})]}

    with ScriptedChat([probe]) as chat:
        config = VlmConfig(base_url=chat.url, model="scripted", max_tool_calls=3)
        with ChatClient(config) as client:
            answer = answer_with_vlm(client, tool_client, world, QUESTION, CHOICES[:2], config)
    assert answer.verdicts == ["wrong", "wrong"]
    assert [c.tool for c in world.calls].count("get_event_time") == 3
    assert answer.extra["model_tool_calls"] == 3
    refused = [v for r in chat.requests for v in tool_results(r).values() if isinstance(v, dict) and "error" in v]
    assert refused and refused[0]["error"]["code"] == "budget_exhausted"
    forced = [r for r in chat.requests if r["tool_choice"] != "auto"]
    assert forced and forced[0]["tool_choice"] == {"type": "function", "function": {"name": SUBMIT_TOOL}}
    assert [t["function"]["name"] for t in forced[0]["tools"]] == [SUBMIT_TOOL]


def test_errors_go_back_to_the_model_and_bad_answers_are_refused(tool_client, world):
    valid = {"answers": [{"choice_id": 1, "verdict": "correct", "reason": "r"}, {"choice_id": 0, "verdict": "wrong", "reason": "r"}]}
    script: list[Step] = [
        lambda r: {"content": None, "tool_calls": [tool_call("bad", "check_contact", {"object_a": 0, "object_b": "red"}),
                                                   tool_call("nojson", "check_contact", "{not json"),
                                                   tool_call("ghost", "teleport", {})]},
        lambda r: {"content": "I think the first one."},
        lambda r: {"content": None, "tool_calls": [tool_call("dup", SUBMIT_TOOL, {"answers": [valid["answers"][0], valid["answers"][0]]})]},
        lambda r: {"content": "```json\n" + json.dumps(valid) + "\n```"},
    ]
    with ScriptedChat(script) as chat:
        config = VlmConfig(base_url=chat.url, model="scripted")
        with ChatClient(config) as client:
            answer = answer_with_vlm(client, tool_client, world, QUESTION, CHOICES[:2], config)
    assert answer.verdicts == ["wrong", "correct"]
    assert answer.extra["rejected_answers"] == 2
    results = tool_results(chat.requests[1])
    assert results["bad"]["error"]["code"] == "invalid_arguments" and results["bad"]["error"]["pointer"] == "/object_b"
    assert results["nojson"]["error"]["code"] == "invalid_json"
    assert results["ghost"]["error"]["code"] == "tool_not_found"
    assert "not a valid answer" in chat.requests[2]["messages"][-1]["content"]
    assert "choice_id must cover" in tool_results(chat.requests[3])["dup"]["error"]["message"]


def test_endpoint_failures_and_endless_conversations_raise(tool_client, world):
    with ScriptedChat([lambda r: {"content": "thinking"}], status=500) as chat:
        config = VlmConfig(base_url=chat.url, model="scripted")
        with ChatClient(config) as client, pytest.raises(VlmError, match="HTTP 500"):
            answer_with_vlm(client, tool_client, world, QUESTION, CHOICES[:2], config)
    with ScriptedChat([lambda r: {"content": "still thinking"}]) as chat:
        config = VlmConfig(base_url=chat.url, model="scripted", max_turns=3)
        with ChatClient(config) as client, pytest.raises(VlmError, match="no valid answer after 3"):
            answer_with_vlm(client, tool_client, world, QUESTION, CHOICES[:2], config)
        assert len(chat.requests) == 3


@pytest.mark.parametrize("kwargs, message", [({"base_url": "localhost:8000", "model": "m"}, "--base-url"),
                                             ({"base_url": "http://x/v1", "model": ""}, "--model"),
                                             ({"base_url": "http://x/v1", "model": "m", "max_tool_calls": -1}, "--max-tool-calls")])
def test_config_errors_name_the_option(kwargs, message):
    with pytest.raises(ValueError, match=message):
        VlmConfig(**kwargs)


def test_config_reads_the_environment(monkeypatch):
    monkeypatch.setenv("OPENAI_BASE_URL", "http://127.0.0.1:9/v1")
    monkeypatch.setenv("OPENAI_MODEL", "env-model")
    monkeypatch.setenv("OPENAI_API_KEY", "env-key")
    config = VlmConfig.from_args(None, None, None)
    assert (config.base_url, config.model, config.api_key) == ("http://127.0.0.1:9/v1", "env-model", "env-key")
    assert VlmConfig.from_args(None, "cli-model", "cli-key").model == "cli-model"


def test_answer_schema_needs_one_verdict_per_choice():
    schema = answer_schema(2)
    jsonschema.validate({"answers": [{"choice_id": 0, "verdict": "wrong", "reason": ""}, {"choice_id": 1, "verdict": "correct", "reason": ""}]}, schema)
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate({"answers": [{"choice_id": 0, "verdict": "maybe", "reason": ""}, {"choice_id": 1, "verdict": "correct", "reason": ""}]}, schema)
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate({"answers": [{"choice_id": 0, "verdict": "wrong", "reason": ""}]}, schema)


def test_ask_command_drives_the_scripted_model(tmp_path, six_document, server_url):
    """``physmind ask --vlm`` against the scripted endpoint, with the world on the session server."""
    world_path = tmp_path / "world.json"
    world_path.write_text(json.dumps(six_document))
    out = tmp_path / "answer.json"
    with ScriptedChat(removal_script()) as chat:
        command = [sys.executable, "-m", "physmind.cli", "ask", "--world", str(world_path), "--server", server_url, QUESTION,
                   *[a for c in CHOICES for a in ("--choice", c)], "--vlm", "--base-url", chat.url, "--model", "scripted", "--json", str(out)]
        completed = subprocess.run(command, capture_output=True, text=True, timeout=120, env={**_env(), "OPENAI_API_KEY": "from-env"})
    assert completed.returncode == 0, completed.stderr
    document = json.loads(out.read_text())
    assert document["method"] == "vlm" and [c["verdict"] for c in document["choices"]][0] == "correct"
    assert [c["tool"] for c in document["tool_call_log"]] == ["get_world_summary", "simulate_edit", "compare_rollouts"]
    assert chat.headers[0].get("Authorization") == "Bearer from-env"
    assert "CORRECT" in completed.stdout


def _env() -> dict:
    return {k: v for k, v in os.environ.items() if not k.startswith(("OPENAI_", "PHYSMIND_API_KEY"))}
