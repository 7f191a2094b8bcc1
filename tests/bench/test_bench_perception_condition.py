"""bench_perception names each video's condition by what the video shows (its renderer's own look)."""

from bench.bench_perception import _condition


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
