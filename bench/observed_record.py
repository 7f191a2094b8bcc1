"""Give worlds fitted before ``World.observed_collisions`` existed the record identify now keeps.

    .venv/bin/python -m bench.observed_record SRC_DIR DST_DIR

For every ``world_XXXXX.json`` in SRC_DIR (a ``bench_qa --cache`` directory):
the fit report's ``collisions_used`` inside the video (identification's stage 1),
then ``world.identify.fit.with_replayed_collisions`` — the last two steps of
``identify``, whose fit is otherwise unchanged with spheres sliding (the default),
less the checks against the tracks (a cached world does not carry them): identify
also leaves out replayed collisions the tracks do not show and one-sided
candidates the replay does not make, which matters for perceived tracks only.
Writes the worlds and their ``build_XXXXX.json`` to DST_DIR, so bench_qa and
bench_identify --worlds score the new record without refitting.
"""

from __future__ import annotations

import dataclasses
import json
import shutil
import sys
from pathlib import Path

from world.identify.fit import with_replayed_collisions
from world.io import world_from_dict, world_to_dict


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 2:
        print(__doc__.strip().splitlines()[2].strip(), file=sys.stderr)
        return 2
    source, target = Path(args[0]), Path(args[1])
    target.mkdir(parents=True, exist_ok=True)
    for path in sorted(source.glob("world_*.json")):
        world = world_from_dict(json.loads(path.read_text()))
        used = world.provenance["fit"]["collisions_used"]
        record = tuple(sorted({(min(a, b), max(a, b), f) for a, b, f in used if 0 <= f < world.observed_frames},
                              key=lambda c: (c[2], c[0], c[1])))
        world = with_replayed_collisions(dataclasses.replace(world, observed_collisions=record))
        (target / path.name).write_text(json.dumps(world_to_dict(world)))
        shutil.copy(source / path.name.replace("world_", "build_"), target)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
