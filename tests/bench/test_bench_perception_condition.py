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
