#!/usr/bin/env bash
# Renders the references of crates/cli/tests/spectral.rs with Mitsuba 3 (llvm_ad_spectral,
# multijitter, 48×48, 16384 spp, in passes of 256 with different seeds) into
# crates/cli/tests/data/NAME-mitsuba-spectral.pfm for NAME in spectral-cbox, spectral-blackbody,
# spectral-metals and the RGB-only glass-mirror-box (examples/mitsuba/NAME.xml, `res` set to 48
# where the scene has that parameter), and with VARIANT=llvm_ad_rgb the RGB references
# NAME-mitsuba-rgb.pfm (spectra converted as Mitsuba's RGB variants do). Mitsuba comes from the bench's virtual environment
# (../shared/bench/mitsuba-time.sh makes it).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
venv=${CANDELA_BENCH_VENV:-$HOME/.cache/candela-bench/venv}
export DRJIT_LIBLLVM_PATH=${DRJIT_LIBLLVM_PATH:-/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1}
spp=${SPP:-16384}
variant=${VARIANT:-llvm_ad_spectral}
suffix=${variant#llvm_ad_}
for name in "${@:-spectral-cbox spectral-blackbody spectral-metals glass-mirror-box}"; do
  for n in $name; do
    "$venv/bin/python" - "$root/examples/mitsuba/$n.xml" "$spp" "$root/crates/cli/tests/data/$n-mitsuba-$suffix.pfm" "$variant" <<'PY'
import sys
import mitsuba as mi, numpy as np
scene_xml, spp, out, variant = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4]
mi.set_variant(variant)
try:
    scene = mi.load_file(scene_xml, res=48)
except Exception:
    scene = mi.load_file(scene_xml)
acc, done, k = 0.0, 0, 0
while done < spp:
    n = min(256, spp - done)
    acc = acc + np.array(mi.render(scene, spp=n, seed=7000 + k), dtype="f8")[:, :, :3] * n
    done += n; k += 1
img = acc / spp
h, w = img.shape[:2]
with open(out, "wb") as f:
    f.write(f"PF\n{w} {h}\n-1.0\n".encode())
    f.write(np.ascontiguousarray(img[::-1], dtype="<f4").tobytes())
print(out, img.reshape(-1, 3).mean(0))
PY
  done
done
