"""Build an executable world from a video (perception + identification) or from tracks.

This is the one part of ``planner/`` that runs in-process rather than over
HTTP: the tool server accepts world documents only (its ``observations`` and
``video`` sources are reserved), so ``physmind build`` produces the document
the server then hosts.

* ``source="video"``: ``perception.pipeline.perceive(video, camera)`` ->
  Observations -> ``world.identify.fit.identify`` -> world;
* ``source="annotation"``: the oracle tracks of a CLEVRER annotation
  (``Observations.from_clevrer_annotation``) -> identify -> world.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

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


def perception_available() -> bool:
    """True when ``perception.pipeline.perceive`` can be imported."""
    try:
        from perception.pipeline import perceive  # noqa: F401
    except ImportError:
        return False
    return True


def build_world(path: Path, source: Source, camera=None, progress: bool = False) -> BuildResult:
    """Video or annotation file -> fitted world document.

    Raises:
        FileNotFoundError: no such input file.
        ValueError: unknown source, or the input cannot be read.
        RuntimeError: ``source="video"`` while the perception pipeline is not installed.
    """
    from world.identify.fit import identify
    from world.identify.observations import Observations
    from world.io import world_to_dict

    if source not in SOURCES:
        raise ValueError(f"source: expected one of {SOURCES}, got {source!r}")
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{source} file not found: {path}")
    started = time.perf_counter()
    if source == "video":
        if camera is None:
            raise ValueError("building from video needs the camera (--camera camera.json: intrinsics + pose)")
        try:
            from perception.pipeline import perceive
        except ImportError:
            raise RuntimeError("building from video needs perception.pipeline.perceive, which is not available in this checkout") from None
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
