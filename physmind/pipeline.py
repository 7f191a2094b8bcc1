"""The video-to-world pipeline: perception + identification, wired in one place.

The stages do not import each other: perception produces ``Observations``
(a ``world`` type), identification turns them into a ``World``. This module,
part of the composition root, runs them in order for one input
(``build_world``) or for a whole dataset (``build_worlds``); the tool server
only ever receives the resulting world documents.

* ``source="video"``: ``perception.pipeline.perceive(video, camera)`` ->
  Observations -> ``world.identify.fit.identify`` -> world;
* ``source="annotation"``: the oracle tracks of a CLEVRER annotation
  (``Observations.from_clevrer_annotation``) -> identify -> world.
"""

from __future__ import annotations

import json
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, Sequence

from tqdm import tqdm

from perception.pipeline import perceive
from physmind.executors import run_jobs
from planner.evaluate import VideoEntry
from world.identify.fit import identify
from world.io import camera_from_dict, world_to_dict
from world.observations import Observations

Source = Literal["video", "annotation"]
SOURCES: tuple[str, ...] = ("video", "annotation")


@dataclass(frozen=True)
class BuildResult:
    """world: the world document (``world.io.world_to_dict``); seconds: wall time of
    the whole build; perception_seconds / fit_seconds: the two stages; rmse: fit
    position RMSE over observed frames (m)."""

    world: dict[str, Any]
    source: str
    seconds: float
    perception_seconds: float
    fit_seconds: float
    rmse: float | None

    def info(self) -> dict[str, Any]:
        return {"source": self.source, "seconds": round(self.seconds, 3), "perception_seconds": round(self.perception_seconds, 3),
                "fit_seconds": round(self.fit_seconds, 3), "rmse_m": None if self.rmse is None else round(self.rmse, 5)}


def build_world(path: Path, source: Source, camera=None, progress: bool = False) -> BuildResult:
    """Video or annotation file -> fitted world document.

    Raises:
        FileNotFoundError: no such input file.
        ValueError: unknown source, or the input cannot be read.
    """
    if source not in SOURCES:
        raise ValueError(f"source: expected one of {SOURCES}, got {source!r}")
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{source} file not found: {path}")
    started = time.perf_counter()
    if source == "video":
        if camera is None:
            raise ValueError("building from video needs the camera (--camera camera.json: intrinsics + pose)")
        observations = perceive(path, camera, progress=progress)
    else:
        observations = Observations.from_clevrer_annotation(path, camera=camera)
    perceived = time.perf_counter()
    world, report = identify(observations)
    finished = time.perf_counter()
    rmse = report.rmse
    document = world_to_dict(world)
    return BuildResult(document, source, finished - started, perceived - started, finished - perceived,
                       float(rmse))


def build_world_from_video_bytes(video: bytes, camera_document: dict[str, Any], suffix: str = ".mp4") -> dict[str, Any]:
    """An uploaded video (its bytes) and camera document -> ``{"world": document, "info": BuildResult.info()}``.

    Takes bytes, not a path, so it runs the same on a Dask worker of another machine.
    Raises ValueError (one line) for a camera or video it cannot build from.
    """
    camera = camera_from_dict(camera_document)
    with tempfile.TemporaryDirectory(prefix="physmind-build-") as folder:
        path = Path(folder) / f"video{suffix}"
        path.write_bytes(video)
        try:
            result = build_world(path, "video", camera)
        except ValueError as error:  # name the upload, not the temporary file
            raise ValueError(str(error).replace(str(path), "the uploaded video")) from None
    return {"world": result.world, "info": result.info()}


# -- building worlds -------------------------------------------------------------------


def _build_one(entry: VideoEntry, source: str) -> tuple[int, dict[str, Any], dict[str, Any]]:
    camera = None if entry.camera_document is None else camera_from_dict(entry.camera_document)
    path = entry.annotation if source == "annotation" else entry.video
    result = build_world(path, source, camera)  # type: ignore[arg-type]
    return entry.scene_index, result.world, result.info()


def build_worlds(entries: Sequence[VideoEntry], source: str, workers: int = 1, cache_dir: Path | None = None,
                 progress: bool = True, dask: str | None = None) -> tuple[dict[int, dict[str, Any]], dict[int, dict[str, Any]]]:
    """World documents (and build info: seconds, rmse) per scene index.

    workers > 1: a local process pool of that size; dask: 'local' (a LocalCluster
    of ``workers`` processes) or a scheduler address (physmind/executors.py).

    cache_dir: worlds already there (``world_XXXXX.json`` + ``build_XXXXX.json``) are reused,
    new ones written. A failing build is recorded in its info (``error``) and has no world.
    """
    worlds: dict[int, dict[str, Any]] = {}
    infos: dict[int, dict[str, Any]] = {}
    todo = []
    for entry in entries:
        if cache_dir is not None:
            world_path, info_path = Path(cache_dir) / f"world_{entry.scene_index:05d}.json", Path(cache_dir) / f"build_{entry.scene_index:05d}.json"
            if world_path.is_file() and info_path.is_file():
                worlds[entry.scene_index] = json.loads(world_path.read_text())
                infos[entry.scene_index] = {**json.loads(info_path.read_text()), "cached": True}
                continue
        todo.append(entry)

    def store(index: int, world: dict[str, Any], info: dict[str, Any]) -> None:
        worlds[index], infos[index] = world, info
        if cache_dir is not None:
            Path(cache_dir).mkdir(parents=True, exist_ok=True)
            (Path(cache_dir) / f"world_{index:05d}.json").write_text(json.dumps(world))
            (Path(cache_dir) / f"build_{index:05d}.json").write_text(json.dumps(info))

    results = run_jobs(_build_one, [(entry, source) for entry in todo], workers, dask)
    bar = tqdm(total=len(todo), desc=f"build ({source})", unit="video", disable=not progress or not todo)
    for position, built, error in results:
        if error is None:
            store(*built)
        else:  # one bad video must not stop the evaluation
            infos[todo[position].scene_index] = {"source": source, "error": f"{type(error).__name__}: {error}"}
        bar.update()
    bar.close()
    return worlds, infos
