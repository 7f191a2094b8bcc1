"""Question-answering benchmark in the layout of the paper's Table 1.

    MUJOCO_GL=egl .venv/bin/physmind synth --out /tmp/qa_bench --scenes 100 --seed 4242 --workers 2
    .venv/bin/python bench/bench_qa.py /tmp/qa_bench --workers 2 [--limit N] [--json results.json]

Rows (per-question and per-option accuracy, %, per question type and overall):

* (a) from video: perception + identification (only when perception/pipeline.py exists);
* (b) oracle tracks: identification from the CLEVRER annotation's tracks, then the
  offline program executor over the HTTP tools;
* (c) trajectory-only ablation: the same worlds, no intervention executed --
  counterfactuals answered from the factual events (the paper's Fig. 4 ablation);
* random guessing, in expectation (each option right with probability 1/2).

Costs: wall time per video of the build (perception + fit) and per question of
the answering (tool calls over loopback HTTP included). ``--cache DIR`` keeps
built worlds (``DIR/<source>/world_XXXXX.json``) for re-runs. The dataset
must not overlap the test fixtures (seed 12); the default command uses seed 4242.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

from physmind.local_server import local_server  # noqa: E402
from physmind.pipeline import build_worlds  # noqa: E402
from planner.client import ToolClient  # noqa: E402
from planner.evaluate import QUESTION_TYPES, Tally, evaluate, format_table, load_dataset  # noqa: E402
from planner.executor import ExecutorConfig  # noqa: E402


def random_row(entries) -> dict[str, Tally]:
    """Expected tallies of guessing each option with probability 1/2 (rounded to whole counts)."""
    expected = {kind: [0, 0.0, 0, 0.0] for kind in (*QUESTION_TYPES, "overall")}
    for entry in entries:
        for question in entry.questions:
            n = len(question["choices"])
            for kind in (question["question_type"], "overall"):
                row = expected.setdefault(kind, [0, 0.0, 0, 0.0])
                row[0] += 1
                row[1] += 0.5 ** n
                row[2] += n
                row[3] += n / 2
    table = {}
    for kind, (questions, q_right, options, o_right) in expected.items():
        tally = Tally(questions, 0, options, 0)
        tally.questions_right = round(q_right)
        tally.options_right = round(o_right)
        table[kind] = tally
    return table


def fixture_overlap(entries) -> int:
    """Scenes whose first-frame object states equal a test fixture's (should be 0)."""
    fixtures = REPO / "tests" / "data" / "synth" / "annotations"
    signatures = set()
    for path in sorted(fixtures.glob("annotation_*.json")):
        document = json.loads(path.read_text())
        signatures.add(json.dumps(document["motion_trajectory"][0], sort_keys=True))
    count = 0
    for entry in entries:
        if entry.annotation.is_file():
            document = json.loads(entry.annotation.read_text())
            count += json.dumps(document["motion_trajectory"][0], sort_keys=True) in signatures
    return count


# no world: the build failed; object absent: the option or question names an object the world lacks (never
# in view); ambiguous: a reference matches several objects; event absent: the explained event is not in the world.
SERVER_START_SECONDS = 300.0

MISS_CAUSES = ("no world", "object absent", "ambiguous ref", "event absent", "undecided other", "decided wrong")


def miss_cause(answer: dict | None, choice: dict | None) -> str:
    """Why an option was missed, from its recorded evidence."""
    if answer is None or choice is None:
        return MISS_CAUSES[0]
    text = " ".join([choice.get("error") or "", answer.get("error") or "", *choice.get("facts", [])])
    if "matches no object" in text:
        return MISS_CAUSES[1]
    if "ambiguous" in text:
        return MISS_CAUSES[2]
    if choice.get("verdict") is None and ("got 0" in text or "disagree" in text):
        return MISS_CAUSES[3]
    return MISS_CAUSES[4] if choice.get("verdict") is None else MISS_CAUSES[5]


def miss_table(reports: dict) -> str:
    """Missed options per row, by cause (counts)."""
    lines = [f"{'missed options by cause':<40}" + "".join(f"{c:>16}" for c in MISS_CAUSES)]
    for label, report in reports.items():
        counts = dict.fromkeys(MISS_CAUSES, 0)
        for record in report["answers"]:
            answer = record["answer"]
            choices = answer["choices"] if answer else [None] * len(record["truth"])
            for choice, truth in zip(choices, record["truth"]):
                if choice is None or choice["verdict"] != truth:
                    counts[miss_cause(answer, choice)] += 1
        lines.append(f"{label:<40}" + "".join(f"{counts[c]:>16}" for c in MISS_CAUSES))
    return "\n".join(lines)


def _cost_line(label: str, infos: dict, result) -> str:
    built = [i["seconds"] for i in infos.values() if "seconds" in i]
    per_question = [r.answer.seconds for r in result.records if r.answer is not None]
    videos = len(result.answer_seconds)
    failed = sum(1 for i in infos.values() if "error" in i)
    build = (f"build {statistics.mean(built):.1f} s/video (median {statistics.median(built):.1f}, max {max(built):.1f}; "
             f"{len(built)} timed, {failed} failed)") if built else "build: all cached"
    answer = (f"answer {1000 * statistics.mean(per_question):.0f} ms/question (median {1000 * statistics.median(per_question):.0f}), "
              f"{sum(result.answer_seconds.values()) / max(videos, 1):.2f} s/video") if per_question else "answer: -"
    return f"{label}: {build}; {answer}"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("data", type=Path, help="dataset directory written by physmind synth")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--limit", type=int, default=None, help="only the first N scenes")
    parser.add_argument("--cache", type=Path, default=None,
                        help="reuse/store built worlds in CACHE/<source>/ (default: no cache, every world is built)")
    parser.add_argument("--skip-video", action="store_true", help="do not run row (a) even if perception exists")
    parser.add_argument("--video-limit", type=int, default=None,
                        help="row (a) on the first N scenes only (perception takes ~1 min per video); (b) and (c) are repeated on them")
    parser.add_argument("--json", type=Path, default=None, help="write every answer with its evidence here")
    args = parser.parse_args(argv)

    entries = load_dataset(args.data, limit=args.limit)
    overlap = fixture_overlap(entries)
    n_questions = sum(len(e.questions) for e in entries)
    print(f"# {len(entries)} scenes, {n_questions} questions from {args.data}; scenes identical to a test fixture: {overlap}")
    reports, costs, tables = {}, [], []
    run_video = not args.skip_video
    if not args.skip_video and not run_video:
        print("# row (a) from video skipped: perception/pipeline.py is not available")
    video_entries = entries[: args.video_limit] if args.video_limit else entries

    # A loaded shared machine can take minutes to start the server (60 s was not enough at load 18).
    with local_server(timeout=SERVER_START_SECONDS) as url, ToolClient(url) as client:
        built = {}
        for source, subset in [("annotation", entries)] + ([("video", video_entries)] if run_video else []):
            cache = None if args.cache is None else args.cache / source
            built[source] = build_worlds(subset, source, args.workers, cache, progress=True)

        def run(label: str, source: str, mode: str, subset) -> dict:
            worlds, infos = built[source]
            infos = {k: v for k, v in infos.items() if k in {e.scene_index for e in subset}}
            result = evaluate(subset, worlds, client, ExecutorConfig(mode=mode), progress=True, build_info=infos)
            costs.append(_cost_line(label, infos if mode == "execute" else {}, result))
            reports[label] = result.to_dict(label, {"source": source, "mode": mode, "scenes": len(subset)})
            return result.table()

        main_rows = {"(b) oracle tracks": run("(b) oracle tracks", "annotation", "execute", entries),
                     "(c) trajectory-only (no execution)": run("(c) trajectory-only (no execution)", "annotation", "trajectory_only", entries),
                     "random guess (expected)": random_row(entries)}
        tables.append((f"all {len(entries)} scenes", main_rows))
        if run_video:
            n = len(video_entries)
            video_rows = {"(a) from video": run(f"(a) from video [{n} scenes]", "video", "execute", video_entries)}
            if n != len(entries):
                video_rows["(b) oracle tracks, same scenes"] = run(f"(b) oracle tracks [{n} scenes]", "annotation", "execute", video_entries)
                video_rows["(c) trajectory-only, same scenes"] = run(f"(c) trajectory-only [{n} scenes]", "annotation", "trajectory_only", video_entries)
                video_rows["random guess (expected)"] = random_row(video_entries)
            tables.append((f"from video: the first {n} scenes", video_rows))

    for title, rows in tables:
        print(f"\n## {title}")
        print(format_table(rows))
    print()
    for line in costs:
        print(line)
    for label, report in reports.items():
        failures = sorted({r["scene_index"] for r in report["answers"] if r["answer"] is None})
        if failures:
            print(f"{label}: {len(failures)} scenes without answers (build or server failure): {failures}")
    print()
    print(miss_table(reports))
    undecided = {label: sum(1 for r in report["answers"] for v in r["verdicts"] if v is None) for label, report in reports.items()}
    print("undecided options (counted wrong): " + ", ".join(f"{k}: {v}" for k, v in undecided.items()))
    if args.json:
        args.json.write_text(json.dumps({"data": str(args.data), "scenes": len(entries), "rows": reports}, indent=1))
        print(f"answers and evidence -> {args.json}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
