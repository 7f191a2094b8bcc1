"""The CLI's promise on bad input: one line on stderr, exit code 2, never a traceback.

One test per bad-input case of the command line (the serve cases are in tests/server/test_serve_cli.py).
"""

from __future__ import annotations

import json
import socket
from pathlib import Path

import pytest

from physmind.cli import main
from physmind.local_server import local_server


def run_cli(argv: list[str], capsys) -> str:
    code = main(argv)
    err = capsys.readouterr().err
    assert code == 2, (code, err)
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    return err


@pytest.fixture()
def annotation(tmp_path):
    path = tmp_path / "annotation_00000.json"
    path.write_text("{}")
    return path


@pytest.mark.parametrize("argv", [
    ["fit", "{input}", "-o", "{dir}"],
    ["build", "{input}", "-o", "{dir}"],
    ["parse", "{input}", "-o", "{dir}"],
    ["perceive", "{input}", "--camera", "{input}", "-o", "{dir}"],
    ["ask", "q?", "--choice", "a", "--world", "{input}", "--json", "{dir}"],
    ["eval", "{dir}", "-o", "{dir}"],
])
def test_output_option_naming_a_directory(argv, annotation, tmp_path, capsys):
    filled = [a.format(input=annotation, dir=tmp_path) for a in argv]
    err = run_cli(filled, capsys)
    assert "is a directory" in err


@pytest.mark.parametrize("content", ["[1, 2, 3]", '"a string"', '{"bodies": []}'])
def test_ask_with_a_world_of_the_wrong_shape(content, tmp_path, capsys):
    world = tmp_path / "world.json"
    world.write_text(content)
    err = run_cli(["ask", "Will the red cube collide?", "--choice", "yes", "--world", str(world)], capsys)
    assert "not a world document" in err


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def test_ask_with_an_unreachable_server(capsys):
    err = run_cli(["ask", "q?", "--choice", "a", "--server", f"http://127.0.0.1:{_free_port()}", "--world-id", "w-x"], capsys)
    assert "cannot reach the tool server" in err


@pytest.fixture(scope="module")
def server_url(tmp_path_factory):
    with local_server(tmp_path_factory.mktemp("cli-server")) as url:
        yield url


def test_ask_with_an_unknown_world_id(server_url, capsys):
    err = run_cli(["ask", "q?", "--choice", "a", "--server", server_url, "--world-id", "w-nope"], capsys)
    assert "world_not_found" in err


def test_ask_with_a_world_the_server_rejects(server_url, scene_builders, tmp_path, capsys):
    from world.io import world_to_dict

    world = tmp_path / "world.json"
    world.write_text(json.dumps({**world_to_dict(scene_builders.six_object_world()), "fps": -1}))
    err = run_cli(["ask", "q?", "--choice", "a", "--server", server_url, "--world", str(world)], capsys)
    assert "HTTP 422 invalid_arguments" in err


def test_synth_out_naming_a_file(tmp_path, capsys):
    target = tmp_path / "file"
    target.write_text("x")
    err = run_cli(["synth", "--out", str(target), "--scenes", "1", "--seed", "1"], capsys)
    assert "is a file" in err


# -- every command that reads a file, against every kind of bad file -----------------------
def test_synth_questions_bad_inputs(tmp_path, capsys):
    err = run_cli(["synth", "questions", str(tmp_path)], capsys)
    assert "no scene_*.json" in err
    (tmp_path / "ground_truth").mkdir()
    (tmp_path / "ground_truth" / "scene_00000.json").write_text('{"scene_index": 0}')
    err = run_cli(["synth", "questions", str(tmp_path)], capsys)
    assert "not a ground-truth file" in err and "scene_00000.json" in err
    err = run_cli(["synth", "questions", str(tmp_path), "--phrasing", "poetic"], capsys)
    assert "--phrasing: expected one of shortest, clevrer" in err


FIXTURES = Path(__file__).resolve().parent / "data" / "synth"
GOOD_ANNOTATION = str(FIXTURES / "annotations" / "annotation_00001.json")
GOOD_CAMERA = str(FIXTURES / "ground_truth" / "scene_00001.json")
GOOD_VIDEO = str(FIXTURES / "videos" / "video_00001.mp4")
FILE_COMMANDS = {  # {bad} is the bad file, {out} an output file
    "fit": ["fit", "{bad}", "-o", "{out}"],
    "build (annotation)": ["build", "{bad}", "--source", "annotation", "-o", "{out}"],
    "build (video)": ["build", "{bad}", "--source", "video", "--camera", GOOD_CAMERA, "-o", "{out}"],
    "build --camera": ["build", GOOD_VIDEO, "--camera", "{bad}", "-o", "{out}"],
    "fit --camera": ["fit", GOOD_ANNOTATION, "--camera", "{bad}", "-o", "{out}"],
    "parse": ["parse", "{bad}", "-o", "{out}"],
    "perceive": ["perceive", "{bad}", "--camera", GOOD_CAMERA, "-o", "{out}", "--quiet"],
    "ask --world": ["ask", "q?", "--choice", "a", "--world", "{bad}"],
    "render": ["render", "{bad}", "-o", "{out}"],
    "eval": ["eval", "{bad}", "-o", "{out}"],
}
BAD_FILES = ("missing", "directory", "empty", "binary", "json_array")


def _bad_file(kind: str, folder: Path) -> Path:
    path = folder / f"{kind}.json"
    if kind == "directory":
        path.mkdir()
    elif kind == "empty":
        path.write_text("")
    elif kind == "binary":
        path.write_bytes(bytes(range(128, 256)) * 3)
    elif kind == "json_array":
        path.write_text("[1, 2]")
    return path


@pytest.mark.parametrize("kind", BAD_FILES)
@pytest.mark.parametrize("command", FILE_COMMANDS)
def test_every_file_reading_command_on_every_bad_file(command, kind, tmp_path, capsys):
    bad = _bad_file(kind, tmp_path)
    argv = [a.format(bad=bad, out=tmp_path / "out.json") for a in FILE_COMMANDS[command]]
    err = run_cli(argv, capsys)
    assert err.startswith(f"physmind {argv[0]}: error: ")


@pytest.mark.parametrize("argv, message", [
    (["eval", "{dir}", "--dask", "scheduler:8786"], "--dask: expected 'local' or a scheduler address"),
    (["eval", "{dir}", "--dask", "tcp://127.0.0.1:{port}"], "cannot reach the Dask scheduler"),
    (["serve", "--dask", "http://x", "--port", "{port}"], "--dask: expected 'local' or a scheduler address"),
])
def test_bad_dask_address(argv, message, tmp_path, capsys):
    (tmp_path / "questions.json").write_text(json.dumps([{"scene_index": 0, "video_filename": "video_00000.mp4", "questions": []}]))
    filled = [a.format(dir=tmp_path, port=_free_port()) for a in argv]
    assert message in run_cli(filled, capsys)
