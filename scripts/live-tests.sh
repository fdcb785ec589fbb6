#!/usr/bin/env bash
# The tests of feedscope watch against real servers on loopback (ignored by a plain
# `cargo test`; docs/live.md): a venv in a temp dir with what the test servers need, then the
# ignored tests whose names contain `watch`, one at a time (they measure delays and replay at
# recorded timing, sped up). Fails when the venv cannot be made or a package not installed.
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
venv="$(mktemp -d)/venv"
trap 'rm -rf "$(dirname "$venv")"' EXIT
python3 -m venv "$venv"
# The MTConnect agent documents of scripts/mtconnect-test-agent.py (pinned: the script works
# round this version's bugs).
"$venv/bin/pip" install --quiet mtconnect==0.3.3 asyncua
# (asyncua: the OPC UA test server of scripts/opcua-test-server.py, for `watch opcua`.)
export FEEDSCOPE_TEST_PYTHON="$venv/bin/python"
cd "$here"
start=$(date +%s)
# (`--workspace --tests`: the test build of the README's test command, not one with other
# features; the name filter picks the tests.)
cargo test --workspace --tests --release --locked -- --ignored --test-threads=1 --nocapture watch
echo "live tests: $(( $(date +%s) - start )) s" >&2
