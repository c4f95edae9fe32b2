#!/usr/bin/env bash
# Renders the references of the bench scenes with Mitsuba 3 (llvm_ad_rgb, multijitter sampler,
# 512×512) into bench/reference/NAME.pfm (little-endian PFM, bottom row first) with
# bench/reference/NAME.json (spp, variant, sampler, date, seconds). Existing references are kept
# unless --force. Makes the meshes first when missing.
#
# Usage: bash bench/references.sh [--force] [--spp N (default 2048)] [NAME ...]
#
# Why multijitter: Mitsuba's ldsampler is biased on the specular box (its red mean is 0.7 %
# below the independent and multijitter samplers' at 256 spp), so it must not make references.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
bench=${CANDELA_BENCH:-$here/../../shared/bench}
venv=${CANDELA_BENCH_VENV:-$HOME/.cache/candela-bench/venv}
force=0; spp=2048; names=()
while [ $# -gt 0 ]; do
  case $1 in
    --force) force=1 ;;
    --spp) spp=$2; shift ;;
    *) names+=("$1") ;;
  esac
  shift
done
[ ${#names[@]} -gt 0 ] || names=(cornell cornell-specular meshes-sky lights-plastic)
[ -e "$here/meshes/bumpy.ply" ] || python3 "$here/make-meshes.py"
if [ ! -x "$venv/bin/python" ]; then
  # mitsuba-time.sh installs Mitsuba (and LLVM) on first use.
  bash "$bench/mitsuba-time.sh" "$here/scenes/cornell.xml" 1 16 /tmp/candela-mitsuba-setup >/dev/null
fi
export DRJIT_LIBLLVM_PATH=${DRJIT_LIBLLVM_PATH:-/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1}
mkdir -p "$here/reference"
for name in "${names[@]}"; do
  out="$here/reference/$name.pfm"
  if [ -e "$out" ] && [ $force = 0 ]; then echo "$out: kept"; continue; fi
  "$venv/bin/python" - "$here/scenes/$name.xml" "$spp" "$out" <<'PY'
import json, os, re, sys, tempfile, time
import mitsuba as mi, numpy as np
scene_xml, spp, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
mi.set_variant("llvm_ad_rgb")
text = re.sub(r'<sampler type="[a-z_]+">', '<sampler type="multijitter">', open(scene_xml).read())
with tempfile.NamedTemporaryFile("w", suffix=".xml", dir=os.path.dirname(scene_xml), delete=False) as f:
    f.write(text)
    tmp = f.name
try:
    scene = mi.load_file(tmp, res=512, spp=spp)
finally:
    os.unlink(tmp)
t = time.perf_counter()
# In passes of at most 512 spp (bounded memory), averaged.
passes = [min(512, spp - k) for k in range(0, spp, 512)]
acc = None
for k, n in enumerate(passes):
    img = np.array(mi.render(scene, spp=n, seed=1000 + k), dtype="f8")[:, :, :3] * n
    acc = img if acc is None else acc + img
img = acc / spp
dt = time.perf_counter() - t
h, w = img.shape[:2]
with open(out, "wb") as f:
    f.write(f"PF\n{w} {h}\n-1.0\n".encode())
    f.write(np.ascontiguousarray(img[::-1], dtype="<f4").tobytes())
json.dump(dict(spp=spp, variant="llvm_ad_rgb", sampler="multijitter", res=512, seconds=round(dt, 1),
               date=time.strftime("%Y-%m-%d %H:%M"), mean=[round(float(x), 5) for x in img.mean(axis=(0, 1))]),
          open(out[:-4] + ".json", "w"), indent=1)
print(f"{out}: {spp} spp in {dt:.0f} s, mean {img.mean(axis=(0, 1))}")
PY
done
