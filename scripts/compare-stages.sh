#!/usr/bin/env bash
# Where a frame's time goes, candela against Mitsuba 3 stage by stage on one thread: each
# renderer at path depth 1, 2 and the scene's own, and (with perf) Mitsuba's time split between
# Embree and the rest of its render (bench/stages.py). Per sample, in nanoseconds.
#
# Usage: bash scripts/compare-stages.sh [SCENE.xml ...] [-- STAGES.PY OPTIONS]
#   e.g. bash scripts/compare-stages.sh bench/scenes/meshes-sky.xml -- --spp 16
# CANDELA_BIN=path skips the build and uses that binary. Needs the bench virtual environment
# (made by scripts/compare-mitsuba.sh) and the meshes (bench/make-meshes.py).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
venv=${CANDELA_BENCH_VENV:-$HOME/.cache/candela-bench/venv}
scenes=(); extra=()
while [ $# -gt 0 ]; do
  if [ "$1" = "--" ]; then shift; extra=("$@"); break; fi
  scenes+=("$1"); shift
done
[ ${#scenes[@]} -gt 0 ] || scenes=("$root"/bench/scenes/*.xml)
if [ -z "${CANDELA_BIN:-}" ]; then
  (cd "$root" && cargo build --release -q)
  CANDELA_BIN=$root/target/release/candela
fi
[ -x "$venv/bin/python" ] || { echo "no bench environment at $venv: run scripts/compare-mitsuba.sh once" >&2; exit 1; }
[ -f "$root/bench/meshes/sky.pfm" ] || python3 "$root/bench/make-meshes.py"
export DRJIT_LIBLLVM_PATH=${DRJIT_LIBLLVM_PATH:-/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1}
"$venv/bin/python" "$root/bench/stages.py" "$CANDELA_BIN" "${scenes[@]}" "${extra[@]}"
