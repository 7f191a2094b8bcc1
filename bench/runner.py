"""One way for the benchmarks to run a function over many tasks on worker processes, with a progress line."""

from __future__ import annotations

import time
from typing import Any, Callable, Sequence

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
