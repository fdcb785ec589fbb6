#!/usr/bin/env bash
# The Python package in CI: build the wheel with maturin (release, abi3), install it into a fresh
# virtual environment, and run the pytest suite of crates/feedscope-py/tests against the
# `feedscope` binary (built here when missing). Needs python3 with venv and PyPI for
# `pip install maturin numpy pytest`; nothing else needs the network.
#
# Environment: FEEDSCOPE_BIN (default target/release/feedscope), PYTHON (default python3),
# PYTEST_ARGS (extra pytest arguments).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
python=${PYTHON:-python3}
export FEEDSCOPE_BIN=${FEEDSCOPE_BIN:-$root/target/release/feedscope}

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

echo "== python package: wheel, fresh venv, pytest against the binary (docs/python.md)"
"$python" -m venv "$tmp/venv"
py="$tmp/venv/bin/python"
"$py" -m pip install -q --disable-pip-version-check maturin numpy pytest

if [ ! -x "$FEEDSCOPE_BIN" ]; then
    echo "== python: building the feedscope binary"
    cargo build --release --locked -p feedscope-cli
fi

echo "== python: wheel (maturin build --release)"
# maturin reads crates/feedscope-py/pyproject.toml: the extension-module feature, --locked.
"$tmp/venv/bin/maturin" build --release -q -m crates/feedscope-py/Cargo.toml -o "$tmp/wheels"
"$py" -m pip install -q --disable-pip-version-check --no-index --find-links "$tmp/wheels" feedscope

echo "== python: pytest"
# Run from the temporary directory so that `import feedscope` is the installed wheel, not the
# source tree's python/ folder.
cd "$tmp"
"$py" -m pytest -q -p no:cacheprovider "$root/crates/feedscope-py/tests" ${PYTEST_ARGS:-}
