#!/usr/bin/env bash
# End-to-end timing of `feedscope estimate` on the 10 M-samples-per-channel trace (≈ 640 MB,
# long layout): wall time and peak resident memory, per input sample.
# The trace is made by the CSV-reading benchmark (target/bench-data/trace_10m.csv) if missing.
# The input is read once before each run so that it comes from the page cache: on a machine
# that pages cold file pages out (e.g. a VM with DAMON proactive reclaim) it would otherwise
# come partly from disk, which measures the disk (≈ 250 MB/s here), not feedscope.
#
# Usage: [READ=auto|stream|whole] scripts/bench-e2e.sh [many|long]
#   READ (default auto) is passed to `feedscope estimate --read`: `whole` reads the trace
#   before estimating, as before the stream (docs/estimation.md, "Estimating while reading").
#   many (default): 400 mm strokes back and forth at 600 mm/min (247 strokes), lead 10 mm.
#   long: one 833 mm stroke at 5 mm/min, simulated by the twin from
#         scripts/bench-long-stroke.toml into target/bench-data/long/ (about 2 min the first time).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -q
case "${1:-many}" in
    many)
        data=target/bench-data/trace_10m.csv
        axis=target/bench-data/axis.toml
        if [ ! -f "$data" ]; then
            cargo bench -p feedscope-io --bench read_csv -- --warm-up-time 1 --measurement-time 1 >/dev/null
        fi
        ;;
    long)
        data=target/bench-data/long/trace.csv
        axis=target/bench-data/long/axis.toml
        if [ ! -f "$data" ]; then
            target/release/feedscope simulate --config scripts/bench-long-stroke.toml \
                --out target/bench-data/long >/dev/null
        fi
        ;;
    *)
        echo "usage: $0 [many|long]" >&2
        exit 2
        ;;
esac
out=$(mktemp -d)
samples=$(( $(wc -l < "$data") - 1 ))
# Run 0 is reported but is the first touch of memory the VM may have handed back to its host
# (see docs/estimation.md, "Cold memory"); runs 1-3 are the steady state.
for run in 0 1 2 3; do
    rm -f "$out/friction.csv"
    cat "$data" >/dev/null
    /usr/bin/time -f "%e %U %S %M" -o "$out/time" target/release/feedscope estimate "$data" --axis "$axis" \
        -o "$out/friction.csv" --no-plot --format json --read "${READ:-auto}" >/dev/null
    read -r wall user sys kb < "$out/time"
    per=$(awk -v kb="$kb" -v n="$samples" 'BEGIN { printf "%.1f", kb * 1024 / n }')
    echo "run $run: ${wall} s wall (${user} s user, ${sys} s system), peak RSS $((kb / 1024)) MiB = $per bytes per input sample ($samples samples)"
done
ls -l "$out/friction.csv" | awk '{print "output CSV: " $5 " bytes"}'
rm -rf "$out"
