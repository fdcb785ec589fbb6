#!/usr/bin/env bash
# End-to-end timing of `feedscope estimate` on the 10 M-samples-per-channel trace (≈ 640 MB,
# long layout): wall time and peak resident memory, per input sample.
# The trace is made by the CSV-reading benchmark (target/bench-data/trace_10m.csv) if missing.
# The input is read once before each run so that it comes from the page cache: on a machine
# that pages cold file pages out (e.g. a VM with DAMON proactive reclaim) it would otherwise
# come partly from disk, which measures the disk (≈ 250 MB/s here), not feedscope.
set -euo pipefail
cd "$(dirname "$0")/.."
data=target/bench-data/trace_10m.csv
axis=target/bench-data/axis.toml
if [ ! -f "$data" ]; then
    cargo bench -p feedscope-io --bench read_csv -- --warm-up-time 1 --measurement-time 1 >/dev/null
fi
cargo build --release -q
out=$(mktemp -d)
samples=$(( $(wc -l < "$data") - 1 ))
# Run 0 is reported but is the first touch of memory the VM may have handed back to its host
# (see docs/estimation.md, "Cold memory"); runs 1-3 are the steady state.
for run in 0 1 2 3; do
    rm -f "$out/friction.csv"
    cat "$data" >/dev/null
    /usr/bin/time -f "%e %U %S %M" -o "$out/time" target/release/feedscope estimate "$data" --axis "$axis" \
        -o "$out/friction.csv" --no-plot --format json >/dev/null
    read -r wall user sys kb < "$out/time"
    echo "run $run: ${wall} s wall (${user} s user, ${sys} s system), peak RSS $((kb / 1024)) MiB = $(( kb * 1024 / samples )) bytes per input sample ($samples samples)"
done
ls -l "$out/friction.csv" | awk '{print "output CSV: " $5 " bytes"}'
rm -rf "$out"
