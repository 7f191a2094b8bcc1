"""bench_perception names each video's condition by what the video shows (its renderer's own look), and lists
the wrong shape decisions by kind."""

from bench.bench_perception import _condition, shape_confusions


def test_mujoco_render_is_named_by_its_look():
    truth = {"look": {"floor": {"texture": "speckle"}, "light": {"shadows": "soft"}}}
    assert _condition(truth) == "speckle floor, soft shadows"
    assert _condition({**truth, "renderer": {"name": "mujoco"}}) == "speckle floor, soft shadows"


def test_ray_traced_render_is_named_by_its_renderer_and_own_floor():
    mujoco_look = {"floor": {"texture": "speckle"}, "light": {"shadows": "soft"}}
    for name in ("povray", "blender"):
        truth = {"look": mujoco_look, "renderer": {"name": name, "look": {"floor": {"kind": "checker"}}}}
        assert _condition(truth) == f"{name}: checker floor"


def test_missing_look_fields_fall_back_to_default():
    assert _condition({}) == "default floor, default shadows"
    assert _condition({"renderer": {"name": "blender", "look": {}}}) == "blender: default floor"


def test_shape_confusions_count_only_the_wrong_decisions_most_frequent_first():
    features = [("cylinder", "metal", "cube", 0.9, 0.8), ("cylinder", "rubber", "cube", 0.2, 0.8),
                ("sphere", "rubber", "sphere", 0.1, 0.9), ("cube", "metal", "cylinder", 0.7, 0.7)]
    assert shape_confusions(features) == "cylinder -> cube 2, cube -> cylinder 1"
    assert shape_confusions(features[2:3]) == "none"


def test_a_video_perception_refuses_counts_its_objects_as_missed_and_the_run_goes_on(tmp_path, capsys):
    # fresh held-out set 63636, scene 54: main's blank check refused a real video and the bench stopped with a traceback
    import json
    import shutil
    from pathlib import Path

    import numpy as np

    from bench.bench_perception import main
    from synth.render import write_mp4

    data = Path(__file__).resolve().parents[1] / "data" / "synth"
    for folder, name in (("ground_truth", "scene_00000.json"), ("masks", "proposal_00000.json"), ("annotations", "annotation_00000.json")):
        (tmp_path / folder).mkdir()
        shutil.copy(data / folder / name, tmp_path / folder / name)
    (tmp_path / "videos").mkdir()
    write_mp4(tmp_path / "videos" / "video_00000.mp4", np.zeros((8, 320, 480, 3), np.uint8), 25.0)  # black frames
    out = tmp_path / "results.json"
    assert main([str(tmp_path), "--no-e2e", "--no-build", "--json", str(out)]) == 0
    (result,) = json.loads(out.read_text())
    assert "blank" in result["refused"] and result["missed_objects"] == result["objects"] > 0
    assert "| videos perception refused (error) | 1; scene 0: video: the frames are blank" in capsys.readouterr().out
