#!/usr/bin/env bash
# The live preview in a real browser: renders the bench Cornell box with --preview, takes a
# headless Chromium screenshot of the page mid-render, and checks that it shows a partial image
# and the status line (the screenshot is kept as docs/preview.png with --update-docs).
# Installs Debian's chromium when it is missing. CANDELA_BIN=path skips the build.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
if ! command -v chromium >/dev/null; then
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null
fi
if [ -z "${CANDELA_BIN:-}" ]; then
  (cd "$root" && cargo build --release -q)
  CANDELA_BIN=$root/target/release/candela
fi
tmp=$(mktemp -d /tmp/candela-preview.XXXXXX)
pid=
cleanup() { if [ -n "$pid" ]; then kill "$pid" 2>/dev/null || true; fi; rm -rf "$tmp"; }
trap cleanup EXIT

"$CANDELA_BIN" render "$root/bench/scenes/cornell.xml" --width 384 --height 384 --spp 4096 \
  --preview -o "$tmp/out.pfm" -q 2>"$tmp/stderr" &
pid=$!
for _ in $(seq 100); do grep -q '^preview: ' "$tmp/stderr" && break; sleep 0.1; done
url=$(sed -n 's/^preview: //p' "$tmp/stderr" | head -1)
[ -n "$url" ] || { echo "test-preview: no address printed" >&2; cat "$tmp/stderr" >&2; exit 1; }
# Wait for a first pass, then let the page load it.
for _ in $(seq 100); do
  curl -sf "${url}status.json" | grep -q '"pass":[1-9]' && break
  sleep 0.1
done
chromium --headless=new --no-sandbox --disable-gpu --hide-scrollbars --window-size=560,520 \
  --virtual-time-budget=4000 --screenshot="$tmp/shot.png" "$url" >/dev/null 2>&1
status=$(curl -sf "${url}status.json")
kill "$pid" 2>/dev/null || true
if [ "${1:-}" = "--update-docs" ]; then cp "$tmp/shot.png" "$root/docs/preview.png"; fi
python3 - "$tmp/shot.png" "$status" <<'PY'
import struct, sys, zlib, json
path, status = sys.argv[1], json.loads(sys.argv[2])
data = open(path, 'rb').read()
assert data[:8] == b'\x89PNG\r\n\x1a\n', 'not a PNG'
# Decode the screenshot (8-bit RGB or RGBA, no interlace) with the standard library.
pos, idat, w = 8, b'', 0
while pos < len(data):
    n, kind = struct.unpack('>I4s', data[pos:pos + 8])
    body = data[pos + 8:pos + 8 + n]
    if kind == b'IHDR':
        w, h, depth, ctype = struct.unpack('>IIBB', body[:10])
    elif kind == b'IDAT':
        idat += body
    pos += 12 + n
bpp = {2: 3, 6: 4}[ctype]
raw, rows, prev = zlib.decompress(idat), [], bytearray(w * bpp)
for y in range(h):
    f, line = raw[y * (w * bpp + 1)], bytearray(raw[y * (w * bpp + 1) + 1:(y + 1) * (w * bpp + 1)])
    for i in range(len(line)):
        a = line[i - bpp] if i >= bpp else 0
        b, c = prev[i], prev[i - bpp] if i >= bpp else 0
        p = a + b - c
        pred = [0, a, b, (a + b) // 2, a if abs(p - a) <= abs(p - b) and abs(p - a) <= abs(p - c) else (b if abs(p - b) <= abs(p - c) else c)][f]
        line[i] = (line[i] + pred) & 255
    rows.append(line); prev = line
# The image area (below the status bar) must show the box: many distinct colours, red and
# green walls; the background of the page is a flat dark grey.
colours = set()
red = green = 0
for y in range(60, h, 3):
    for x in range(0, w, 3):
        r, g, b = rows[y][x * bpp:x * bpp + 3]
        colours.add((r, g, b))
        red += r > g + 20 and r > b + 20
        green += g > r + 10 and g > b + 10
assert len(colours) > 200, f'the screenshot shows no image ({len(colours)} colours)'
assert red > 50 and green > 50, f'no red and green walls ({red}, {green})'
assert status['state'] == 'rendering' and 0 < status['spp_done'] < status['spp_total'], status
print(f"test-preview: screenshot {w}x{h} with {len(colours)} colours mid-render "
      f"({status['spp_done']}/{status['spp_total']} spp)")
PY

