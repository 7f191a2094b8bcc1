"""bench.bench_grey_floor's table and its bad input (the MuJoCo run itself: tests/perception/test_perception_floor_like_tops.py)."""

from __future__ import annotations

from bench.bench_grey_floor import main, table


def test_the_table_counts_per_true_shape():
    rows = [("cube", "cube", 0.01), ("cube", "sphere", 0.15), ("cylinder", "sphere", 0.02), ("sphere", "sphere", 0.04)]
    lines = {line.split()[0]: line for line in table(rows).splitlines()[1:]}
    assert lines["cube"].split()[1:4] == ["2", "0.500", "0.500"] and "cube->sphere 1" in lines["cube"]
    assert lines["sphere"].split()[1:4] == ["1", "0.000", "1.000"] and lines["sphere"].endswith("-")
    assert lines["all"].split()[1:4] == ["4", "0.500", "0.500"]
    assert "cylinder->sphere 1" in lines["all"] and "cube->sphere 1" in lines["all"]


def test_no_scenes_is_a_clear_error(capsys):
    assert main(["--scenes", "0"]) == 2
    assert "--scenes" in capsys.readouterr().err
