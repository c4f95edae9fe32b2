#!/usr/bin/env bash
# Compares candela with Mitsuba 3 on a Mitsuba XML scene in one run, as the bench README asks:
# render time, RMSE against a reference image, and efficiency = 1 / (time × MSE), each as a
# ratio candela / Mitsuba (> 1: candela is better).
# Usage: bash scripts/compare-mitsuba.sh [SCENE.xml] [SPP=64] [REFERENCE.pfm] [SAMPLER=sobol]
# Defaults: ../shared/bench/cornell.xml at 512×512 against its reference. Needs python3 (the
# Mitsuba timing script installs Mitsuba from PyPI on first use).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
bench=${CANDELA_BENCH:-$root/../shared/bench}
scene=${1:-$bench/cornell.xml}; spp=${2:-64}; ref=${3:-$bench/cornell-reference.pfm}
sampler=${4:-sobol}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
(cd "$root" && cargo build --release -q)
bash "$bench/mitsuba-time.sh" "$scene" "$spp" 512 "$out/mitsuba" | tee "$out/mitsuba.txt"
"$root/target/release/candela" render "$scene" --spp "$spp" --sampler "$sampler" --stats -q \
  -o "$out/candela.pfm" 2>&1 | tee "$out/candela.txt"
python3 - "$ref" "$out" <<'PY'
import array, re, sys
ref_path, out = sys.argv[1], sys.argv[2]
def load(path):
    data = open(path, "rb").read()
    magic, size, scale, rest = data.split(b"\n", 3)
    w, h = map(int, size.split())
    a = array.array("f")
    a.frombytes(rest[: w * h * 12])
    if float(scale) > 0:
        a.byteswap()
    return a
ref = load(ref_path)
def mse(a):
    # Emitter pixels are clamped so that their (huge) noise does not dominate.
    return sum((min(x, 50.0) - min(y, 50.0)) ** 2 for x, y in zip(a, ref)) / len(ref)
rows = {}
for line in open(f"{out}/mitsuba.txt"):
    m = re.match(r"mitsuba (\S+): .* in ([0-9.]+) s", line)
    if m:
        rows[f"mitsuba {m.group(1)}"] = (float(m.group(2)), mse(load(f"{out}/mitsuba-{m.group(1)}.pfm")))
m = re.search(r"\): ([0-9.]+) s,", open(f"{out}/candela.txt").read())
rows["candela"] = (float(m.group(1)), mse(load(f"{out}/candela.pfm")))
ct, cm = rows["candela"]
for name, (t, e) in rows.items():
    print(f"{name:22s} {t:7.2f} s  RMSE {e ** 0.5:.5f}  efficiency {1 / (t * e):9.1f}"
          + ("" if name == "candela" else
             f"   candela/this: speed {t / ct:.2f}x, efficiency {(t * e) / (ct * cm):.2f}x"))
PY
