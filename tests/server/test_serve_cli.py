"""``physmind serve`` is registered and rejects bad arguments without a traceback."""

from __future__ import annotations

import subprocess
import sys

import pytest

from physmind.cli import build_parser, main


def test_serve_is_a_subcommand_with_host_port_and_data_dir():
    args = build_parser().parse_args(["serve", "--host", "0.0.0.0", "--port", "9000", "--data-dir", "/tmp/d"])
    assert (args.host, args.port, str(args.data_dir)) == ("0.0.0.0", 9000, "/tmp/d")
    assert callable(args.handler)


@pytest.mark.parametrize("port", ["0", "70000"])
def test_bad_port_is_a_one_line_error(port, capsys):
    assert main(["serve", "--port", port]) == 2
    err = capsys.readouterr().err
    assert "--port" in err and "Traceback" not in err


def test_bad_environment_is_a_one_line_error():
    result = subprocess.run([sys.executable, "-m", "physmind.cli", "serve", "--port", "8"],
                            env={"PHYSMIND_MAX_REQUEST_BYTES": "x", "PATH": ""}, capture_output=True, text=True, timeout=60)
    assert result.returncode == 2 and "PHYSMIND_MAX_REQUEST_BYTES" in result.stderr and "Traceback" not in result.stderr


# -- safe by default and clean errors before uvicorn starts -------------------------------
def _serve(argv, capsys, monkeypatch, env=None):
    for name in ("PHYSMIND_API_KEY", "PHYSMIND_DATA_DIR"):
        monkeypatch.delenv(name, raising=False)
    for name, value in (env or {}).items():
        monkeypatch.setenv(name, value)
    code = main(["serve", *argv])
    err = capsys.readouterr().err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    return code, err


def _free_port() -> int:
    import socket

    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def test_non_loopback_without_a_key_is_refused(capsys, monkeypatch, tmp_path):
    code, err = _serve(["--host", "0.0.0.0", "--data-dir", str(tmp_path)], capsys, monkeypatch)
    assert code == 2 and "PHYSMIND_API_KEY" in err and "--insecure" in err


def test_busy_port_is_one_line(capsys, monkeypatch, tmp_path):
    import socket

    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        code, err = _serve(["--port", str(port), "--data-dir", str(tmp_path)], capsys, monkeypatch)
    assert code == 2 and "already in use" in err


@pytest.mark.parametrize("host", ["no-such-host.invalid", "300.1.1.1", "exa mple"])
def test_bad_host_is_one_line(host, capsys, monkeypatch, tmp_path):
    code, err = _serve(["--host", host, "--port", str(_free_port()), "--data-dir", str(tmp_path), "--insecure"], capsys, monkeypatch)
    assert code == 2 and "--host" in err


def test_data_dir_that_is_a_file(capsys, monkeypatch, tmp_path):
    path = tmp_path / "file"
    path.write_text("x")
    code, err = _serve(["--port", str(_free_port()), "--data-dir", str(path)], capsys, monkeypatch)
    assert code == 2 and "is a file" in err


def test_corrupt_sqlite_file(capsys, monkeypatch, tmp_path):
    (tmp_path / "physmind.sqlite3").write_bytes(b"this is not a database" * 100)
    code, err = _serve(["--port", str(_free_port()), "--data-dir", str(tmp_path)], capsys, monkeypatch)
    assert code == 2 and "not a usable PhysMind registry" in err


def test_sqlite_path_that_is_a_directory(capsys, monkeypatch, tmp_path):
    (tmp_path / "physmind.sqlite3").mkdir()
    code, err = _serve(["--port", str(_free_port()), "--data-dir", str(tmp_path)], capsys, monkeypatch)
    assert code == 2 and "is a directory" in err


def test_second_server_on_one_data_dir_is_refused(capsys, monkeypatch, tmp_path):
    from server.datadir import lock_data_dir

    held = lock_data_dir(tmp_path)
    try:
        code, err = _serve(["--port", str(_free_port()), "--data-dir", str(tmp_path)], capsys, monkeypatch)
    finally:
        held.close()
    assert code == 2 and "in use by another physmind server" in err


def test_loopback_names_are_recognised():
    from server.serve_cli import is_loopback

    assert is_loopback("127.0.0.1") and is_loopback("localhost") and is_loopback("::1")
    assert not is_loopback("0.0.0.0") and not is_loopback("10.0.0.1")
