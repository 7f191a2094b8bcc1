"""One way for the benchmarks to run a function over many tasks on worker processes, with a progress line;
the annotated scenes of a dataset, and a table printed with its rows saved as JSON."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any, Callable, Iterable, Sequence

from physmind.executors import run_jobs


def run_with_progress(fn: Callable[[Any], Any], tasks: Sequence[Any], workers: int, unit: str) -> list[Any]:
    """``fn(task)`` for every task, in completion order, on ``workers`` processes (physmind.executors.run_jobs;
    in this process for one worker), printing ``k/n unit (s)`` on one line as they finish. ``fn`` turns a
    failing task into a row of its own; an exception it still raises stops the benchmark."""
    results = []
    began = time.perf_counter()
    for done, (_, result, error) in enumerate(run_jobs(fn, [(task,) for task in tasks], workers), 1):
        if error is not None:
            raise error
        results.append(result)
        print(f"\r{done}/{len(tasks)} {unit} ({time.perf_counter() - began:.0f} s)", end="", flush=True)
    print()
    return results


def dataset_annotations(dataset: Path, limit: int | None = None) -> list[Path]:
    """The first ``limit`` (all: None) ``annotations/annotation_*.json`` of a generated dataset, sorted;
    SystemExit with a one-line message when there are none."""
    annotations = sorted((dataset / "annotations").glob("annotation_*.json"))[:limit]
    if not annotations:
        raise SystemExit(f"no annotations under {dataset / 'annotations'}")
    return annotations


def print_and_save(lines: Iterable[str], rows: Any, json_path: Path | None) -> None:
    """Print the table ``lines``; write ``rows`` as JSON to ``json_path`` when given."""
    for line in lines:
        print(line)
    if json_path:
        json_path.write_text(json.dumps(rows, indent=1))
