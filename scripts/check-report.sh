#!/usr/bin/env bash
# Render the demo's condition report in headless Chromium and check it: the DOM has every
# section, the screenshot is a non-trivial PNG. Installs Debian's chromium when missing.
# Usage: scripts/check-report.sh [FEEDSCOPE_BINARY]   (default: target/release/feedscope)
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${1:-target/release/feedscope}

if ! command -v chromium >/dev/null 2>&1; then
    echo "installing chromium (Debian package) ..." >&2
    if [ "$(id -u)" = 0 ]; then sudo=""; else sudo="sudo"; fi
    $sudo apt-get update -qq >/dev/null
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq chromium >/dev/null
fi

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$bin" demo --out "$work/demo" --weeks 12 >/dev/null 2>"$work/demo.log" || {
    cat "$work/demo.log" >&2; exit 1; }
report="$work/demo/report.html"
test -s "$report"

flags=(--headless --no-sandbox --disable-gpu --disable-quic --no-first-run
       --disable-background-networking --disable-component-update --disable-sync
       --hide-scrollbars --run-all-compositor-stages-before-draw --virtual-time-budget=5000)

# The DOM after layout: every section and the inline plots must be there.
chromium "${flags[@]}" --user-data-dir="$work/profile-dom" --dump-dom "file://$report" \
    >"$work/dom.html" 2>"$work/chromium-dom.log"
for id in summary diagnosis profile spectra stribeck trends tables; do
    grep -q "id=\"$id\"" "$work/dom.html" || { echo "report DOM lacks section #$id" >&2; exit 1; }
done
svgs=$(grep -o '<svg' "$work/dom.html" | wc -l)
[ "$svgs" -ge 10 ] || { echo "report DOM has only $svgs inline SVG plots" >&2; exit 1; }
grep -q "lubrication" "$work/dom.html" || { echo "report diagnosis does not mention lubrication" >&2; exit 1; }

# A screenshot: a PNG of the right size with many distinct byte values (not a blank page).
png=${REPORT_PNG:-$work/report.png}
chromium "${flags[@]}" --user-data-dir="$work/profile-png" --window-size=1280,4000 \
    --screenshot="$png" "file://$report" >/dev/null 2>"$work/chromium-png.log"
test -s "$png" || { echo "no screenshot written" >&2; cat "$work/chromium-png.log" >&2; exit 1; }
python3 - "$png" <<'PY'
import struct, sys, zlib
data = open(sys.argv[1], "rb").read()
assert data[:8] == b"\x89PNG\r\n\x1a\n", "not a PNG"
w, h = struct.unpack(">II", data[16:24])
assert (w, h) == (1280, 4000), f"unexpected size {w}x{h}"
# Decompress the image data and count distinct scanline bytes: a blank page has a handful.
pos, idat = 8, b""
while pos < len(data):
    n = struct.unpack(">I", data[pos:pos + 4])[0]
    if data[pos + 4:pos + 8] == b"IDAT":
        idat += data[pos + 8:pos + 8 + n]
    pos += 12 + n
raw = zlib.decompress(idat)
distinct = len(set(raw[i:i + 3] for i in range(0, min(len(raw), 3_000_000), 3)))
assert distinct > 200, f"screenshot looks blank ({distinct} distinct pixel triples)"
assert len(data) > 50_000, f"screenshot suspiciously small ({len(data)} bytes)"
print(f"report screenshot {w}x{h}, {len(data)} bytes, {distinct} distinct pixel triples")
PY
echo "report renders: $svgs inline plots, all sections present"
