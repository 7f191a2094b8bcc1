"""Exact-match benchmark of the question parser against official CLEVRER programs.

    .venv/bin/python bench/bench_parser.py [QUESTIONS.json ...]

Default input: the 564 real CLEVRER explanatory questions (2,256 choices) in
``../shared/clevrer/clevrer_explanatory_train_subset.json``. Prints, per
question type, the exact program match for questions and for choices, every
miss (text, official program, parsed program or parse error), and the parse
throughput. Texts are compared after mapping CLEVRER's release-file operator
spellings to DESIGN.md's (``planner.parser.normalize_program``).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

from planner.cli import format_report  # noqa: E402
from planner.parser import parse_question_file  # noqa: E402

# shared/ sits beside the checkout (CI's fresh clone) or at /work/shared (an engineer's worktree).
DEFAULT_INPUT = next(
    (path.resolve() for path in (REPO / ".." / "shared", Path("/work/shared"))
     if (path / "clevrer" / "clevrer_explanatory_train_subset.json").is_file()),
    (REPO / ".." / "shared").resolve(),
) / "clevrer" / "clevrer_explanatory_train_subset.json"


def bench_file(path: Path, repeats: int) -> int:
    document = json.loads(path.read_text(encoding="utf-8"))
    started = time.perf_counter()
    for _ in range(repeats):
        result = parse_question_file(document)
    elapsed = (time.perf_counter() - started) / repeats
    summary = result.summary()
    n_texts = summary["questions"]["total"] + summary["choices"]["total"]

    print(f"# {path}")
    print(format_report(result))
    print(f"unparsed texts: {len(result.unparsed)}")
    print(f"parse time: {elapsed * 1e3:.1f} ms for {n_texts} texts "
          f"({n_texts / elapsed:,.0f} texts/s, mean of {repeats} runs)")
    if result.misses:
        print(f"misses ({len(result.misses)}):")
        for miss in result.misses:
            where = f"scene {miss.scene_index} q{miss.question_id}"
            if miss.kind == "choice":
                where += f" c{miss.choice_id}"
            print(f"- [{miss.question_type} {miss.kind}, {where}] {miss.text!r}")
            print(f"    official: {' '.join(miss.official)}")
            print(f"    parsed:   {' '.join(miss.parsed) if miss.parsed is not None else miss.error}")
    else:
        print("misses: none")
    return len(result.misses)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("files", nargs="*", type=Path, default=[DEFAULT_INPUT], metavar="QUESTIONS.json")
    parser.add_argument("--repeats", type=int, default=5, help="timing runs per file (default 5)")
    args = parser.parse_args(argv)
    for path in args.files:
        if not path.is_file():
            print(f"bench_parser: question file not found: {path}", file=sys.stderr)
            return 2
    for path in args.files:
        bench_file(path, max(1, args.repeats))
        print()
    return 0


if __name__ == "__main__":
    sys.exit(main())
