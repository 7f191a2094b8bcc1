"""``physmind parse``: CLEVRER question file -> the same file with parsed programs.

    physmind parse QUESTIONS.json -o programs.json

The output document is ``{"source", "questions", "unparsed", "summary"}``:
``questions`` keeps the input's layout (CLEVRER's list, or the dict keyed by
scene index) with each question's and choice's ``program`` replaced by the
parsed program (``null`` when unparsed) and the input's program kept as
``official_program``; ``unparsed`` lists every text the grammar rejected with
the parser's message. When the input carries official programs the
exact-match rate is printed per question type.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from planner.parser import FileParse, TypeMatch, parse_question_file


def register(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "parse",
        help="parse CLEVRER-style questions and choices into programs",
        description=(
            "Parse every question and choice text of a CLEVRER question file (CLEVRER's list "
            "format or a dict keyed by scene index) into CLEVRER programs."
        ),
    )
    parser.add_argument("questions", type=Path, metavar="QUESTIONS.json", help="CLEVRER-format question file")
    parser.add_argument("-o", "--output", type=Path, required=True, metavar="programs.json",
                        help="where to write the file with parsed programs")
    parser.set_defaults(handler=run_parse)


def _rate(exact: int, with_official: int) -> str:
    rate = TypeMatch.rate(exact, with_official)
    return "-" if rate is None else f"{exact}/{with_official} = {100 * rate:.2f} %"


def format_report(result: FileParse) -> str:
    """The exact-match table printed by ``physmind parse``."""
    lines = [f"{'type':<16}{'questions exact':>28}{'choices exact':>28}"]
    for question_type, match in sorted(result.per_type.items()):
        lines.append(
            f"{question_type:<16}{_rate(match.questions_exact, match.questions_with_official):>28}"
            f"{_rate(match.choices_exact, match.choices_with_official):>28}"
        )
    summary = result.summary()
    lines.append(
        f"{'all':<16}"
        f"{_rate(summary['questions']['exact'], summary['questions']['with_official_program']):>28}"
        f"{_rate(summary['choices']['exact'], summary['choices']['with_official_program']):>28}"
    )
    return "\n".join(lines)


def run_parse(args: argparse.Namespace) -> int:
    path: Path = args.questions
    if not path.is_file():
        raise FileNotFoundError(f"question file not found: {path}")
    try:
        document = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as error:
        raise ValueError(f"{path} is not valid JSON: {error}") from None
    result = parse_question_file(document)
    summary = result.summary()
    output = {
        "source": str(path),
        "questions": result.document,
        "unparsed": list(result.unparsed),
        "summary": summary,
    }
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps(output, indent=1) + "\n", encoding="utf-8")

    n_questions = summary["questions"]["total"]
    n_choices = summary["choices"]["total"]
    print(f"parsed {n_questions} questions and {n_choices} choices from {path}; "
          f"{len(result.unparsed)} unparsed; wrote {args.output}")
    for kind, count in summary["skipped_questions"].items():
        print(f"skipped {count} {kind} questions (outside the grammar)")
    if summary["questions"]["with_official_program"] or summary["choices"]["with_official_program"]:
        print("exact program match against the file's official programs:")
        print(format_report(result))
    for item in result.unparsed[:20]:
        print(f"unparsed: {item['error']}", file=sys.stderr)
    if len(result.unparsed) > 20:
        print(f"... and {len(result.unparsed) - 20} more unparsed texts (see {args.output})", file=sys.stderr)
    return 0
