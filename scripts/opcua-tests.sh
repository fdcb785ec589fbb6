#!/usr/bin/env bash
# Runs the OPC UA source's tests against a real OPC UA server (scripts/opcua-test-server.py,
# PyPI asyncua) in a throw-away venv. Needs python3 with venv and access to PyPI.
#
#   scripts/opcua-tests.sh            # all of crates/feedscope-live/tests/opcua.rs
#   scripts/opcua-tests.sh reconnect  # extra arguments go to the test binary (a filter)
#
# The ignored tests fail, not skip, without FEEDSCOPE_TEST_PYTHON; this script sets it.
set -euo pipefail
cd "$(dirname "$0")/.."

venv="$(mktemp -d "${TMPDIR:-/tmp}/feedscope-opcua-venv.XXXXXX")"
trap 'rm -rf "$venv"' EXIT
python3 -m venv "$venv"
"$venv/bin/pip" install --quiet --disable-pip-version-check asyncua
export FEEDSCOPE_TEST_PYTHON="$venv/bin/python"

# --include-ignored: the server tests (ignored by default) and the config tests, in one run;
# one test at a time, so that server start-up and the reconnect timing do not compete.
# (`--workspace`: the test build of the README's test command, not one with other features.)
cargo test --workspace --release --locked --test opcua -- --include-ignored --nocapture --test-threads=1 "$@"
