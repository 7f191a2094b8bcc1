"""A real small model drives the tools: how its tool calls fare over N questions.

Builds one world per video of a CLEVRER-layout dataset (oracle tracks), starts
the tool server and the local model server (SmolLM2-135M-Instruct on
llama-cpp-python, physmind/model_server.py), and answers the first N questions
with ``planner.vlm.answer_with_vlm``. Prints: tool calls the model made, valid
ones (executed, HTTP 200), errors handed back (schema errors, unknown ids or
tools, non-JSON) and how many a later call of the same tool recovered,
answers submitted, loops that ended on the turn budget, crashes (anything
else: must be 0), per-option and per-question accuracy against the dataset's
truth, tokens and seconds per question. No prompt or setting is tuned to the
model; its accuracy is reported as it is.

    physmind synth --out /tmp/agent_bench --scenes 8 --seed 7171
    nice -n 10 .venv/bin/python -m bench.bench_agent /tmp/agent_bench --questions 50 [--json report.json]
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

from physmind.local_server import local_server
from physmind.model_server import MODEL_ALIAS, model_server
from physmind.pipeline import build_worlds
from planner.client import ToolClient
from planner.evaluate import load_dataset
from planner.executor import prediction_horizon_for
from planner.vlm import ChatClient, VlmConfig, VlmError, answer_with_vlm

DEFAULT_TOOLS = "check_contact,list_events,simulate_edit,get_world_summary"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dataset", type=Path)
    parser.add_argument("--questions", type=int, default=50)
    parser.add_argument("--videos", type=int, default=None, help="only the first N videos of the dataset")
    parser.add_argument("--tools", default=DEFAULT_TOOLS, help=f"world tools offered (default {DEFAULT_TOOLS}; 'all' for every tool)")
    parser.add_argument("--max-tool-calls", type=int, default=4)
    parser.add_argument("--max-turns", type=int, default=6)
    parser.add_argument("--json", type=Path, default=None, help="per-question records")
    parser.add_argument("--time-budget", type=float, default=None,
                        help="seconds after which no new question is started (the table says how many were asked)")
    args = parser.parse_args(argv)
    entries = load_dataset(args.dataset, limit=args.videos)
    worlds, _ = build_worlds(entries, "annotation", progress=True)
    tool_names = None if args.tools == "all" else tuple(t.strip() for t in args.tools.split(",") if t.strip())
    records: list[dict] = []
    deadline = None if args.time_budget is None else time.monotonic() + args.time_budget
    with local_server() as url, ToolClient(url) as tools, model_server() as base_url:
        config = VlmConfig(base_url=base_url, model=MODEL_ALIAS, max_tool_calls=args.max_tool_calls,
                           max_turns=args.max_turns, timeout_s=900, tool_names=tool_names)
        with ChatClient(config) as chat:
            for entry in entries:
                if entry.scene_index not in worlds:
                    continue
                world = tools.create_world(worlds[entry.scene_index], horizon_frames=prediction_horizon_for(worlds[entry.scene_index]))
                for question in entry.questions:
                    if len(records) >= args.questions or (deadline is not None and time.monotonic() > deadline):
                        break
                    choices = [c["choice"] for c in question["choices"]]
                    truth = [c.get("answer") for c in question["choices"]]
                    started = time.perf_counter()
                    record = {"scene_index": entry.scene_index, "question_id": question["question_id"],
                              "question": question["question"], "truth": truth}
                    try:
                        answer = answer_with_vlm(chat, tools, world, question["question"], choices, config)
                        record.update(outcome="submitted", verdicts=answer.verdicts, stats=answer.extra)
                    except VlmError as error:
                        record.update(outcome="turn budget" if error.stats else "endpoint error", error=str(error)[:300],
                                      stats=error.stats)
                    except Exception as error:  # noqa: BLE001 -- counted: the target is 0 crashes
                        record.update(outcome="crash", error=f"{type(error).__name__}: {error}"[:300], stats={})
                    record["seconds"] = time.perf_counter() - started
                    records.append(record)
                    print(f"[{len(records)}/{args.questions}] {record['outcome']} {record['seconds']:.0f} s "
                          f"{json.dumps(record.get('stats', {}))}", file=sys.stderr, flush=True)
    if args.json:
        args.json.write_text(json.dumps(records, indent=1))
    print(format_report(records, args))
    return 0


def format_report(records: list[dict], args: argparse.Namespace) -> str:
    def total(key: str) -> int:
        return sum(r["stats"].get(key, 0) for r in records if r.get("stats"))

    options = [(v, t) for r in records if r["outcome"] == "submitted" for v, t in zip(r["verdicts"], r["truth"])]
    all_options = sum(len(r["truth"]) for r in records)
    right_options = sum(v == t for v, t in options)
    right_questions = sum(r["outcome"] == "submitted" and list(r["verdicts"]) == list(r["truth"]) for r in records)
    outcomes = {k: sum(r["outcome"] == k for r in records) for k in ("submitted", "turn budget", "endpoint error", "crash")}
    prompt = [r["stats"]["usage"].get("prompt_tokens", 0) for r in records if r.get("stats", {}).get("usage")]
    completion = [r["stats"]["usage"].get("completion_tokens", 0) for r in records if r.get("stats", {}).get("usage")]
    seconds = [r["seconds"] for r in records]
    n = len(records)
    rows = [
        ("questions", n),
        ("tool calls made by the model (incl. submit_answer)", total("model_calls")),
        ("world tool calls valid (HTTP 200)", total("ok_calls")),
        ("errors handed back (schema, unknown id/tool, non-JSON)", total("failed_calls")),
        ("  of which recovered by a later call of the same tool", total("recovered_calls")),
        ("answers rejected by the answer schema", total("rejected_answers")),
        ("answers submitted", outcomes["submitted"]),
        ("ended on the chat-request budget (no answer)", outcomes["turn budget"]),
        ("endpoint errors", outcomes["endpoint error"]),
        ("crashes of the loop", outcomes["crash"]),
        ("accuracy per option (no answer = wrong)", f"{100 * right_options / max(all_options, 1):.1f} % ({right_options}/{all_options})"),
        ("accuracy per question", f"{100 * right_questions / max(n, 1):.1f} % ({right_questions}/{n})"),
        ("prompt tokens per question (mean)", f"{statistics.fmean(prompt):.0f}" if prompt else "-"),
        ("completion tokens per question (mean)", f"{statistics.fmean(completion):.0f}" if completion else "-"),
        ("seconds per question (mean / median)", f"{statistics.fmean(seconds):.1f} / {statistics.median(seconds):.1f}" if seconds else "-"),
    ]
    header = (f"model {MODEL_ALIAS} (llama-cpp-python, chatml-function-calling), tools {args.tools}, "
              f"max {args.max_tool_calls} tool calls, {args.max_turns} chat requests per question")
    return "\n".join([header, "", "| measure | value |", "|---|---:|", *[f"| {k} | {v} |" for k, v in rows]])


if __name__ == "__main__":
    sys.exit(main())
