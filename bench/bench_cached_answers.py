"""Answer a dataset's questions on the worlds cached by bench_attribution (no perception, no fitting).

    nice -n 10 .venv/bin/python bench/bench_cached_answers.py DATA CACHE [--limit 12] [--rows "from video,oracle tracks"] [--strip-beliefs]

For before/after comparisons of the planner on identical worlds: run it with
another checkout's packages first on the path (``PYTHONPATH=OLD_SRC``; e.g.
``git archive COMMIT | tar -x -C OLD_SRC``), as a script rather than with
``-m`` (``-m`` puts the current directory first, ahead of OLD_SRC). --strip-beliefs drops each body's
``attribute_belief`` (world documents older than the beliefs do not know it).
Prints the Table-1 layout, the questions with an ungrounded reference and the
undecided options per row.
"""

from __future__ import annotations

import argparse
import copy
import json
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.append(str(REPO))  # appended: a checkout given by PYTHONPATH comes first

from physmind.local_server import local_server  # noqa: E402
from planner.client import ToolClient  # noqa: E402
from planner.evaluate import evaluate, format_table, load_dataset  # noqa: E402
from planner.executor import ExecutorConfig  # noqa: E402

# What an undecided reference says (planner.grounding's messages, and the older "ambiguous" / "matches no object").
UNGROUNDED_MARKS = ("cannot ground", "is ambiguous", "matches no object", "has no objects")


def _ungrounded(error: str | None) -> bool:
    return error is not None and any(mark in error for mark in UNGROUNDED_MARKS)


def ungrounded_questions(records) -> int:
    """Questions (planner.evaluate.QuestionRecord) whose answer, or one of whose options, was left undecided
    for want of a grounded reference."""
    return sum(1 for r in records if r.answer is not None and (_ungrounded(r.answer.error) or any(
        c.verdict is None and _ungrounded(c.error) for c in r.answer.choices)))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("data", type=Path, help="dataset written by physmind synth")
    parser.add_argument("cache", type=Path, help="bench_attribution --cache directory")
    parser.add_argument("--limit", type=int, default=None, help="only the first N scenes")
    parser.add_argument("--rows", default="from video,oracle tracks", help="comma-separated rows of the cache")
    parser.add_argument("--strip-beliefs", action="store_true", help="remove bodies' attribute_belief before serving")
    args = parser.parse_args(argv)
    entries = load_dataset(args.data, limit=args.limit)
    missing = [e.scene_index for e in entries if not (args.cache / f"scene_{e.scene_index:05d}.json").is_file()]
    if missing:
        raise SystemExit(f"cache: no result for scenes {missing} in {args.cache}")
    cached = {e.scene_index: json.loads((args.cache / f"scene_{e.scene_index:05d}.json").read_text()) for e in entries}
    tables = {}
    with local_server() as url, ToolClient(url) as client:
        for row in [r.strip() for r in args.rows.split(",") if r.strip()]:
            worlds = {}
            for index, result in cached.items():
                world = result["rows"].get(row, {}).get("world")
                if world is None:
                    continue
                if args.strip_beliefs:
                    world = copy.deepcopy(world)
                    for body in world["bodies"]:
                        body.pop("attribute_belief", None)
                worlds[index] = world
            evaluated = evaluate(entries, worlds, client, ExecutorConfig(mode="execute"), progress=False,
                                 build_info={i: {"error": "no world in the cache"} for i in cached if i not in worlds})
            tables[row] = evaluated.table()
            ungrounded = ungrounded_questions(evaluated.records)
            undecided = sum(1 for r in evaluated.records for v in r.verdicts if v is None)
            print(f"{row}: questions with an ungrounded reference {ungrounded} of {len(evaluated.records)}; undecided options {undecided}")
    print(format_table(tables))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
