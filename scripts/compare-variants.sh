#!/usr/bin/env bash
# candela against Mitsuba 3 on scenes without a reference: the variants of the four kinds in
# bench/extra/ (or the scenes given), efficiency from the variance over renders with different
# seeds (bench/seed-variance.py), all in one run. A check that a speed or sampling change is
# general, not tuned to the four bench scenes.
#
# Usage: bash scripts/compare-variants.sh [SCENE.xml ...] [-- SEED-VARIANCE.PY OPTIONS]
#   e.g. bash scripts/compare-variants.sh bench/extra/cornell-3lights.xml -- --seeds 8
# CANDELA_BIN=path skips the build and uses that binary. Needs the bench virtual environment
# (made by scripts/compare-mitsuba.sh) and the meshes and sky (bench/make-meshes.py).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
venv=${CANDELA_BENCH_VENV:-$HOME/.cache/candela-bench/venv}
scenes=(); extra=()
while [ $# -gt 0 ]; do
  if [ "$1" = "--" ]; then shift; extra=("$@"); break; fi
  scenes+=("$1"); shift
done
[ ${#scenes[@]} -gt 0 ] || scenes=("$root"/bench/extra/*.xml)
if [ -z "${CANDELA_BIN:-}" ]; then
  (cd "$root" && cargo build --release -q)
  CANDELA_BIN=$root/target/release/candela
fi
[ -x "$venv/bin/python" ] || { echo "no bench environment at $venv: run scripts/compare-mitsuba.sh once" >&2; exit 1; }
[ -f "$root/bench/meshes/sky.pfm" ] || python3 "$root/bench/make-meshes.py"
export DRJIT_LIBLLVM_PATH=${DRJIT_LIBLLVM_PATH:-/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1}
echo "CPU: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs); $(nproc) cores;" \
  "AVX-512: $(grep -qw avx512f /proc/cpuinfo && echo yes || echo no)"
"$venv/bin/python" "$root/bench/seed-variance.py" "$CANDELA_BIN" "${scenes[@]}" "${extra[@]}"
