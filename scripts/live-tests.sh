#!/usr/bin/env bash
# The tests of feedscope watch against real servers on loopback (ignored by a plain
# `cargo test`): a venv in a temp dir with what the test servers need, then the ignored tests.
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
venv="$(mktemp -d)/venv"
trap 'rm -rf "$(dirname "$venv")"' EXIT
python3 -m venv "$venv"
"$venv/bin/pip" install --quiet mtconnect==0.3.3
export FEEDSCOPE_TEST_PYTHON="$venv/bin/python"
cd "$here"
cargo test --release --locked -p feedscope-live -p feedscope-cli -- --ignored watch
