#!/bin/sh
# The one install recipe of the server image, shared by docker/Dockerfile and
# the packaging test (tests/test_packaging.py), so the test checks what the
# image runs: a built wheel installed without -e into a fresh venv.
#
#   docker/install.sh wheel SRC OUT    build the wheel of the source tree SRC into OUT (from a clean copy of SRC)
#   docker/install.sh deps VENV SRC    create VENV with the pinned runtime dependencies of SRC/pyproject.toml
#                                      (SRC/constraints.txt); only these two files are read, so the Dockerfile
#                                      can run this step in a layer before the source arrives
#   docker/install.sh app VENV WHEEL   install the wheel into VENV (no -e, no dependency resolution) and `pip check`
#
# PYTHON (default python3) is the interpreter that creates the venv.
set -eu

PYTHON="${PYTHON:-python3}"
PIP_QUIET="--quiet --disable-pip-version-check"

usage() {
    echo "usage: $0 wheel SRC OUT | deps VENV SRC | app VENV WHEEL" >&2
    exit 2
}

[ $# -eq 3 ] || usage
step="$1"

case "$step" in
wheel)
    src="$2"; out="$3"
    # Build from a copy without build/, *.egg-info and .venv: setuptools never
    # deletes stale files from build/lib, which would then ship in the wheel.
    copy="$(mktemp -d)"; builder="$(mktemp -d)"
    trap 'rm -rf "$copy" "$builder"' EXIT
    tar -C "$src" --exclude=./.venv --exclude=./.git --exclude=./build --exclude='*.egg-info' \
        --exclude=./out --exclude=./data --exclude=./tests --exclude=__pycache__ -cf - . | tar -C "$copy" -xf -
    mkdir -p "$out"
    # pip from a throwaway venv: Debian's python3 has no pip module, its venvs do.
    "$PYTHON" -m venv "$builder"
    "$builder/bin/python" -m pip wheel $PIP_QUIET --no-deps --wheel-dir "$out" "$copy"
    ;;
deps)
    venv="$2"; src="$3"
    "$PYTHON" -m venv "$venv"
    requirements="$(mktemp)"
    "$venv/bin/python" - "$src/pyproject.toml" > "$requirements" <<'PY'
import sys, tomllib
with open(sys.argv[1], "rb") as handle:
    print("\n".join(tomllib.load(handle)["project"]["dependencies"]))
PY
    "$venv/bin/python" -m pip install $PIP_QUIET -c "$src/constraints.txt" -r "$requirements"
    rm -f "$requirements"
    ;;
app)
    venv="$2"; wheel="$3"
    "$venv/bin/python" -m pip install $PIP_QUIET --no-deps "$wheel"
    "$venv/bin/python" -m pip check
    ;;
*)
    usage
    ;;
esac
