"""bench.synth_energy: kinetic energy after / before an isolated collision, from a ground truth's positions."""

from __future__ import annotations

import json

import numpy as np

from bench.pair_mujoco import pair_spec, run_pair
from bench.synth_energy import collision_energy_ratios, main


def _document(shapes: tuple[str, str], speeds_after: tuple[float, float] | None = None) -> dict:
    """A ground-truth-shaped document of one MuJoCo impact (1.6 s); ``speeds_after``: replace both bodies'
    motion after the hit by these speeds along +x (m/s), to stage an impact that gains energy."""
    spec = pair_spec(shapes, 2.0, 0.0, (0.08, 0.08))
    result = run_pair(spec, 1.6)
    hit = result.collisions[0].frame
    positions = result.positions.copy()
    if speeds_after is not None:
        for k, speed in enumerate(speeds_after):
            steps = np.arange(1, positions.shape[0] - hit) / spec.fps
            positions[hit + 1 :, k, 0] = positions[hit, k, 0] + speed * steps
    return {
        "fps": spec.fps,
        "objects": [{"object_id": o.object_id, "shape": o.shape, "mass": o.mass, "launch_frame": o.launch_frame} for o in spec.objects],
        "trajectory": {"objects": [{"object_id": o.object_id, "location": positions[:, k].tolist()} for k, o in enumerate(spec.objects)]},
        "events": [{"kind": "collision", "object_ids": list(c.bodies), "frame_id": c.frame} for c in result.collisions],
    }


def test_a_mujoco_impact_loses_energy_and_a_staged_gain_is_counted(tmp_path, capsys):
    ((pair, ratio),) = collision_energy_ratios(_document(("cube", "cube")))
    assert pair == "cube-cube" and 0.3 < ratio < 1.0
    ((_, gained),) = collision_energy_ratios(_document(("cube", "cube"), speeds_after=(2.0, 2.0)))
    assert gained > 1.5  # both leave at the striker's speed: twice the energy it brought
    (tmp_path / "ground_truth").mkdir()
    (tmp_path / "ground_truth" / "scene_00000.json").write_text(json.dumps(_document(("cube", "cube"), speeds_after=(2.0, 2.0))))
    assert main([str(tmp_path)]) == 0
    assert "cube-cube                   1           1" in capsys.readouterr().out


def test_a_directory_without_ground_truth_is_a_clear_error(tmp_path, capsys):
    assert main([str(tmp_path)]) == 2
    assert "no ground_truth/scene_*.json" in capsys.readouterr().err
