"""``physmind serve`` is registered and rejects bad arguments without a traceback."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

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


def test_serve_help_lists_every_environment_variable_the_server_reads():
    """Every PHYSMIND_* name read in server/ code (not its docs) is in `physmind serve --help`."""
    read = set()
    for path in (Path(__file__).resolve().parents[2] / "server").glob("*.py"):
        code = re.sub(r'""".*?"""', "", path.read_text(), flags=re.S)  # docstrings document, they do not read
        read |= set(re.findall(r'"(PHYSMIND_[A-Z_]+)"', code))
    assert {"PHYSMIND_DATA_DIR", "PHYSMIND_API_KEY", "PHYSMIND_MAX_BODIES"} <= read, read
    result = subprocess.run([sys.executable, "-m", "physmind.cli", "serve", "--help"], capture_output=True, text=True, timeout=60)
    assert result.returncode == 0, result.stderr
    listed = set(re.findall(r"^\s+(PHYSMIND_[A-Z_]+)\s", result.stdout, flags=re.M))
    assert read <= listed, f"not in serve --help: {sorted(read - listed)}"
