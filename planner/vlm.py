"""A thin VLM client: any OpenAI-compatible chat-completions endpoint drives the world tools.

The model gets the question, its choices, the world summary and the tools of
``GET /v1/tools`` (OpenAI function-calling format, unchanged) plus one extra
function, ``submit_answer``, whose parameters are the answer schema: one
verdict ("correct" / "wrong") per choice with a short reason. Every tool call
the model makes is executed against the tool server (``POST
/v1/worlds/{id}/tools/{name}``) and the result -- or the server's structured
error, so the model can fix its arguments -- goes back as a ``tool`` message.
The loop ends when the model submits a valid answer (through
``submit_answer`` or as a JSON message matching the schema). A tool-call
budget bounds the work: once spent, only ``submit_answer`` is offered and
required.

Works with vLLM, Ollama, llama.cpp server and hosted APIs: only
``/chat/completions`` with ``tools`` / ``tool_calls`` is used. Configuration:
``--base-url`` / ``--model`` / ``--api-key`` or ``OPENAI_BASE_URL`` /
``OPENAI_MODEL`` / ``OPENAI_API_KEY``.
"""

from __future__ import annotations

import json
import os
import time
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import httpx
import jsonschema

from planner.answer import Answer, ChoiceAnswer
from planner.client import ToolClient, WorldHandle
from planner.grammar import ParseError
from planner.parser import parse_question

SUBMIT_TOOL = "submit_answer"


def answer_schema(choice_count: int) -> dict[str, Any]:
    """JSON Schema of a final answer: exactly one verdict per choice id 0..choice_count-1."""
    return {
        "type": "object",
        "properties": {
            "answers": {
                "type": "array",
                "minItems": choice_count,
                "maxItems": choice_count,
                "items": {
                    "type": "object",
                    "properties": {
                        "choice_id": {"type": "integer", "minimum": 0, "maximum": max(choice_count - 1, 0)},
                        "verdict": {"type": "string", "enum": ["correct", "wrong"]},
                        "reason": {"type": "string", "description": "the tool evidence (events, frames, rollout ids) behind the verdict"},
                    },
                    "required": ["choice_id", "verdict", "reason"],
                    "additionalProperties": False,
                },
            }
        },
        "required": ["answers"],
        "additionalProperties": False,
    }


def submit_tool(choice_count: int) -> dict[str, Any]:
    return {"type": "function", "function": {
        "name": SUBMIT_TOOL,
        "description": "Submit the final answer: one verdict per choice (correct or wrong), each with the evidence from the tools.",
        "parameters": answer_schema(choice_count)}}


SYSTEM_PROMPT = """You answer multiple-choice questions about a physical scene recorded on video.
The scene has been turned into an executable world that you query through tools: inspect states and events,
continue the motion beyond the video, remove an object and replay, compare rollouts.
Rules:
- Ground every object description ("the red cube") to an object id with the world summary. Each description names
  exactly one object: the same one in the question and every choice; "the brown object" and "the brown cube" are one
  object; descriptions that differ in a colour, material or shape ("the gray cube", "the gray cylinder") are two.
- Observed events are those before the video's last frame (observed_frames); later events are predictions.
- For "what happens if X is removed", replay without X (simulate_edit with edit_type remove_object) and look at the
  collisions before the end of the video in that rollout.
- For "which event will happen next", look at events beyond the observed frames. The question presupposes that one
  of its events happens: if the continuation shows none of them, the pair that comes closest (check_contact's
  nearest_distance) is the answer; say it is uncertain.
- For "responsible for" questions, an event's causes are the earlier events of the objects involved, recursively.
  The explained event happened: when a description fits several objects, take the one with which it did.
- Otherwise judge every choice independently; several or none may be correct.
Finish by calling submit_answer (or replying with the same JSON) with one verdict per choice and the evidence."""


class VlmError(RuntimeError):
    """The chat endpoint failed or the conversation could not reach an answer.

    stats: the conversation's counts so far (as ``Answer.extra``), when there was one.
    """

    def __init__(self, message: str, stats: Mapping[str, Any] | None = None) -> None:
        super().__init__(message)
        self.stats = dict(stats or {})


@dataclass(frozen=True)
class VlmConfig:
    """base_url: the OpenAI-compatible API root (``.../v1``); api_key: bearer token or None.
    max_tool_calls: world tool calls per question; max_turns: chat requests per question;
    max_result_chars: longer tool results are cut (with a note) before they reach the model.
    tool_names: the world tools offered (None: all of ``GET /v1/tools``); a small
    model's context and speed may only afford a few."""

    base_url: str
    model: str
    api_key: str | None = None
    max_tool_calls: int = 24
    max_turns: int = 40
    temperature: float = 0.0
    timeout_s: float = 120.0
    max_result_chars: int = 16000
    tool_names: tuple[str, ...] | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.base_url, str) or not self.base_url.startswith(("http://", "https://")):
            raise ValueError(f"--base-url: expected http(s)://..., got {self.base_url!r} (or set OPENAI_BASE_URL)")
        if not self.model:
            raise ValueError("--model: a model name is required (or set OPENAI_MODEL)")
        if self.max_tool_calls < 0:
            raise ValueError(f"--max-tool-calls: expected >= 0, got {self.max_tool_calls}")
        if self.max_turns < 1:
            raise ValueError(f"max_turns: expected >= 1, got {self.max_turns}")

    @classmethod
    def from_args(cls, base_url: str | None, model: str | None, api_key: str | None, **kwargs: Any) -> "VlmConfig":
        """Arguments first, then OPENAI_BASE_URL / OPENAI_MODEL / OPENAI_API_KEY."""
        return cls(base_url=base_url or os.environ.get("OPENAI_BASE_URL", ""), model=model or os.environ.get("OPENAI_MODEL", ""),
                   api_key=api_key if api_key is not None else (os.environ.get("OPENAI_API_KEY") or None), **kwargs)


class ChatClient:
    """POST {base_url}/chat/completions over httpx."""

    def __init__(self, config: VlmConfig, transport: httpx.BaseTransport | None = None):
        headers = {"Authorization": f"Bearer {config.api_key}"} if config.api_key else {}
        self.config = config
        self.http = httpx.Client(base_url=config.base_url.rstrip("/"), headers=headers, timeout=config.timeout_s, transport=transport)

    def close(self) -> None:
        self.http.close()

    def __enter__(self) -> "ChatClient":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def complete(self, messages: Sequence[Mapping[str, Any]], tools: Sequence[Mapping[str, Any]],
                 tool_choice: Any = "auto") -> tuple[dict[str, Any], dict[str, Any]]:
        """One chat completion; returns (assistant message, usage)."""
        body = {"model": self.config.model, "messages": list(messages), "tools": list(tools), "tool_choice": tool_choice,
                "temperature": self.config.temperature}
        try:
            response = self.http.post("/chat/completions", json=body)
        except httpx.HTTPError as error:
            raise VlmError(f"chat endpoint {self.config.base_url}: {error}") from None
        if response.status_code >= 400:
            raise VlmError(f"chat endpoint answered HTTP {response.status_code}: {response.text[:500]}")
        try:
            payload = response.json()
            message = payload["choices"][0]["message"]
        except (ValueError, KeyError, IndexError, TypeError):
            raise VlmError(f"chat endpoint gave no choices[0].message: {response.text[:500]}") from None
        return dict(message), dict(payload.get("usage") or {})


@dataclass
class _Transcript:
    """What happened in one conversation.

    model_calls: tool calls the model made (any name); failed_calls: those
    answered with an error (unknown tool, non-JSON, schema or id error);
    recovered: failed calls followed later by a successful call of the same tool.
    """

    turns: int = 0
    tool_calls: list[int] = field(default_factory=list)
    rejected_answers: int = 0
    usage: dict[str, int] = field(default_factory=dict)
    model_calls: int = 0
    ok_calls: int = 0
    failed_calls: int = 0
    recovered: int = 0
    _pending: list[str] = field(default_factory=list)

    def add_usage(self, usage: Mapping[str, Any]) -> None:
        for key, value in usage.items():
            if isinstance(value, int):
                self.usage[key] = self.usage.get(key, 0) + value

    def outcome(self, name: str, ok: bool) -> None:
        """Count one tool call's outcome (a failure is recovered by a later success of the same tool)."""
        if not ok:
            self.failed_calls += 1
            self._pending.append(name)
            return
        self.ok_calls += 1
        if name in self._pending:
            self.recovered += self._pending.count(name)
            self._pending = [n for n in self._pending if n != name]

    def stats(self) -> dict[str, Any]:
        return {"chat_requests": self.turns, "model_calls": self.model_calls, "model_tool_calls": len(self.tool_calls) - 1,
                "ok_calls": self.ok_calls, "failed_calls": self.failed_calls, "recovered_calls": self.recovered,
                "rejected_answers": self.rejected_answers, "usage": dict(self.usage)}


def _parse_answer(raw: Any, choice_count: int) -> tuple[dict[str, Any] | None, str | None]:
    """(answer, None) when ``raw`` (a JSON string or object) is a valid answer, else (None, what is wrong)."""
    if isinstance(raw, str):
        text = raw.strip()
        if text.startswith("```"):
            text = text.strip("`")
            text = text[text.index("\n") + 1:] if "\n" in text else text
        start, end = text.find("{"), text.rfind("}")
        if start < 0 or end < start:
            return None, "no JSON object found"
        try:
            raw = json.loads(text[start:end + 1])
        except json.JSONDecodeError as error:
            return None, f"invalid JSON: {error.msg}"
    try:
        jsonschema.validate(raw, answer_schema(choice_count))
    except jsonschema.ValidationError as error:
        where = "/".join(str(p) for p in error.absolute_path)
        return None, f"does not match the answer schema at '/{where}': {error.message}"
    ids = sorted(item["choice_id"] for item in raw["answers"])
    if ids != list(range(choice_count)):
        return None, f"choice_id must cover 0..{choice_count - 1} exactly once, got {ids}"
    return raw, None


def _user_prompt(question: str, choices: Sequence[str], summary: Mapping[str, Any]) -> str:
    lines = [f"Question: {question}", "Choices:"]
    lines += [f"  {k}: {text}" for k, text in enumerate(choices)]
    lines += ["", "World summary (get_world_summary):", json.dumps(summary, separators=(",", ":"))]
    return "\n".join(lines)


def _first_message(text: str, images: Sequence[str]) -> str | list[dict[str, Any]]:
    """The first user message: plain text, or text then images (OpenAI content parts) when frames are attached."""
    if not images:
        return text
    parts: list[dict[str, Any]] = [{"type": "text", "text": text + f"\n\n{len(images)} frames of the video follow, evenly spaced in time."}]
    parts += [{"type": "image_url", "image_url": {"url": url}} for url in images]
    return parts


def answer_with_vlm(chat: ChatClient, tools_client: ToolClient, world: WorldHandle, question: str, choices: Sequence[str],
                    config: VlmConfig | None = None, images: Sequence[str] = ()) -> Answer:
    """Run the function-calling loop for one question; the Answer cites the model's tool calls.

    images: URLs (``data:image/png;base64,...``) of video frames attached to
    the first user message, as the paper gives its VLM the observation clip;
    empty for text-only models.

    Raises:
        VlmError: the endpoint failed, or no valid answer within ``max_turns`` requests.
    """
    config = config or chat.config
    started = time.perf_counter()
    if not choices:
        raise ValueError("choices: at least one choice is needed")
    world_tools = tools_client.tools()
    if config.tool_names is not None:
        offered = {tool["function"]["name"] for tool in world_tools}
        unknown = sorted(set(config.tool_names) - offered)
        if unknown:
            raise ValueError(f"--tools: unknown tools {unknown}; the server has {sorted(offered)}")
        world_tools = [tool for tool in world_tools if tool["function"]["name"] in config.tool_names]
    known = {tool["function"]["name"] for tool in world_tools}
    summary = world.call("get_world_summary")
    transcript = _Transcript(tool_calls=[world.last_call.index])
    all_tools = [*world_tools, submit_tool(len(choices))]
    only_submit = [submit_tool(len(choices))]
    force_submit = {"type": "function", "function": {"name": SUBMIT_TOOL}}
    messages: list[dict[str, Any]] = [
        {"role": "system", "content": SYSTEM_PROMPT},
        {"role": "user", "content": _first_message(_user_prompt(question, choices, summary), images)},
    ]
    budget_spent = config.max_tool_calls == 0
    while transcript.turns < config.max_turns:
        transcript.turns += 1
        message, usage = chat.complete(messages, only_submit if budget_spent else all_tools, force_submit if budget_spent else "auto")
        transcript.add_usage(usage)
        calls = message.get("tool_calls") or []
        # Echo the turn back with "" for a null content: OpenAI allows null beside tool_calls, but
        # llama-cpp-python's server refuses null and its chat template needs the key (a real model found this).
        assistant: dict[str, Any] = {"role": "assistant", "content": message.get("content") or ""}
        if calls:
            assistant["tool_calls"] = calls
        messages.append(assistant)
        if not calls:
            answer, problem = _parse_answer(message.get("content") or "", len(choices))
            if answer is not None:
                return _to_answer(question, choices, answer, world, transcript, started)
            transcript.rejected_answers += 1
            messages.append({"role": "user", "content": f"Your reply is not a valid answer ({problem}). Call {SUBMIT_TOOL} "
                                                        f"with one verdict per choice id 0..{len(choices) - 1}."})
            continue
        submitted: dict[str, Any] | None = None
        for call in calls:
            call_id = call.get("id") or f"call_{transcript.turns}"
            function = call.get("function") or {}
            name = function.get("name")
            arguments_text = function.get("arguments") or "{}"
            transcript.model_calls += 1
            if name == SUBMIT_TOOL:
                answer, problem = _parse_answer(arguments_text, len(choices))
                if answer is not None:
                    submitted = answer
                    content = "answer received"
                else:
                    transcript.rejected_answers += 1
                    content = json.dumps({"error": {"code": "invalid_answer", "message": problem}})
            elif name not in known:
                transcript.outcome(str(name), False)
                content = json.dumps({"error": {"code": "tool_not_found", "message": f"no tool {name!r}", "valid_ids": sorted(known)}})
            elif len(transcript.tool_calls) - 1 >= config.max_tool_calls:
                budget_spent = True
                content = json.dumps({"error": {"code": "budget_exhausted",
                                                "message": f"the tool-call budget ({config.max_tool_calls}) is spent; call {SUBMIT_TOOL} now"}})
            else:
                try:
                    arguments = json.loads(arguments_text) if isinstance(arguments_text, str) else dict(arguments_text)
                except json.JSONDecodeError as error:
                    transcript.outcome(name, False)
                    content = json.dumps({"error": {"code": "invalid_json", "message": f"arguments are not JSON: {error.msg}"}})
                else:
                    if not isinstance(arguments, dict):
                        transcript.outcome(name, False)
                        content = json.dumps({"error": {"code": "invalid_arguments", "message": "arguments must be a JSON object"}})
                    else:
                        status, body, record = world.call_raw(name, arguments)
                        transcript.outcome(name, status == 200)
                        transcript.tool_calls.append(record.index)
                        content = json.dumps(body, separators=(",", ":"))
                        if len(content) > config.max_result_chars:
                            content = content[: config.max_result_chars] + f"... [cut at {config.max_result_chars} characters; ask for less detail]"
                        if len(transcript.tool_calls) - 1 >= config.max_tool_calls:
                            budget_spent = True
            messages.append({"role": "tool", "tool_call_id": call_id, "content": content})
        if submitted is not None:
            return _to_answer(question, choices, submitted, world, transcript, started)
        if budget_spent:
            messages.append({"role": "user", "content": f"The tool-call budget is spent. Call {SUBMIT_TOOL} now."})
    raise VlmError(f"no valid answer after {config.max_turns} chat requests ({len(transcript.tool_calls) - 1} tool calls)",
                   transcript.stats())


def _to_answer(question: str, choices: Sequence[str], answer: Mapping[str, Any], world: WorldHandle, transcript: _Transcript,
               started: float) -> Answer:
    try:
        question_type: str | None = parse_question(question).question_type
    except ParseError:
        question_type = None  # the model may answer questions outside the grammar
    by_id = {item["choice_id"]: item for item in answer["answers"]}
    verdicts = tuple(ChoiceAnswer(k, text, None, by_id[k]["verdict"], facts=(f"model: {by_id[k]['reason']}",))
                     for k, text in enumerate(choices))
    return Answer(question, question_type, None, verdicts, method="vlm", tool_calls=tuple(transcript.tool_calls),
                  seconds=time.perf_counter() - started,
                  extra=transcript.stats())
