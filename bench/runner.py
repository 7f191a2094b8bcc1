"""One way for the benchmarks to run a function over many tasks on worker processes, with a progress line;
the annotated scenes of a dataset, and a table printed with its rows saved as JSON."""

from __future__ import annotations

import argparse
import json
import time
from functools import partial
from pathlib import Path
from typing import Any, Callable, Iterable, Sequence

import numpy as np

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


def scene_world(annotation: Path, observations: Any, worlds: Path | None, save_worlds: Path | None) -> Any:
    """The fitted world of a miss report's scene: ``worlds/world_XXXXX.json`` when present, else identified from
    ``observations`` (and written to ``save_worlds`` when given); XXXXX is the annotation's index."""
    from world.identify.fit import identify
    from world.io import world_from_dict, world_to_dict

    index = annotation.stem.split("_")[-1]
    cached = None if worlds is None else worlds / f"world_{index}.json"
    if cached is not None and cached.is_file():
        return world_from_dict(json.loads(cached.read_text()))
    world, _ = identify(observations)
    if save_worlds is not None:
        save_worlds.mkdir(parents=True, exist_ok=True)
        (save_worlds / f"world_{index}.json").write_text(json.dumps(world_to_dict(world)))
    return world


def median_cm(rows: list[dict], key: str, width: int) -> str:
    """The median of ``key`` (metres) over ``rows``, in cm, right-aligned in ``width``; "n/a" when none is finite."""
    values = np.array([r[key] for r in rows], dtype=float) * 100
    return f"{np.nanmedian(values):>{width}.1f}" if np.isfinite(values).any() else f"{'n/a':>{width}}"


def failed_lines(rows: list[dict]) -> list[str]:
    """One line per scene whose rows failed (``_rows_or_error``)."""
    return [f"failed: scene {r['scene']}: {r['error']}" for r in rows if r["kind"] == "error"]


def _rows_or_error(scene_rows: Callable[[Any], list[dict]], task: tuple) -> list[dict]:
    """``scene_rows(task)``, or one error row naming the scene (task[0], an annotation path)."""
    try:
        return scene_rows(task)
    except Exception as error:  # noqa: BLE001 - the table reports failures
        return [{"scene": task[0].stem, "kind": "error", "error": f"{type(error).__name__}: {error}"}]


def miss_report_main(argv: list[str] | None, description: str, scene_rows: Callable[[Any], list[dict]],
                     table: Callable[[list[dict]], list[str]], workers: int) -> int:
    """The command line of the per-scene miss reports (bench_future_misses, bench_observed_misses):
    ``scene_rows((annotation, worlds dir, save-worlds dir))`` per scene on ``workers`` processes by
    default, then ``table(rows)`` printed and the rows saved with --json."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("dataset", type=Path)
    parser.add_argument("--scenes", type=int, default=None)
    parser.add_argument("--workers", type=int, default=workers)
    parser.add_argument("--worlds", type=Path, default=None, help="read fitted worlds (world_XXXXX.json) from here when present")
    parser.add_argument("--save-worlds", type=Path, default=None, help="write the fitted worlds here")
    parser.add_argument("--json", type=Path, default=None, help="write every miss / invention here")
    args = parser.parse_args(argv)
    tasks = [(a, args.worlds, args.save_worlds) for a in dataset_annotations(args.dataset, args.scenes)]
    rows = [row for scene in run_with_progress(partial(_rows_or_error, scene_rows), tasks, args.workers, "scenes") for row in scene]
    print_and_save(table(rows), rows, args.json)
    return 0
