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
