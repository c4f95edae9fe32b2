#!/usr/bin/env bash
# candela against Mitsuba 3 on the bench scenes, in one run: the issue-13 table.
#
# For each scene of bench/scenes/ (or the NAMEs given), Mitsuba llvm_ad_rgb renders with each
# of its samplers (independent, multijitter, ldsampler; render call only, warm JIT) and candela
# renders as a whole process (its default sampler and independent), all at 512×512, 64 spp, in
# the same run; each image's RMSE against bench/reference/NAME.pfm gives the efficiency
# 1 / (time × MSE) relative to Mitsuba's best sampler (../shared/bench/efficiency.py).
#
# Usage: bash scripts/compare-mitsuba.sh [NAME ...] [-- EFFICIENCY.PY OPTIONS]
#   e.g. bash scripts/compare-mitsuba.sh cornell -- --goal 1.5 --candela-samplers default
# CANDELA_BIN=path skips the build and uses that binary. Meshes and references are made when
# missing (bench/make-meshes.py, bench/references.sh: Mitsuba at 2048 spp, a few minutes each).
set -euo pipefail
. "$(dirname "$0")/bench-common.sh"
bench=${CANDELA_BENCH:-$root/../shared/bench}
bench_args "$@"
names=("${args[@]}")
[ ${#names[@]} -gt 0 ] || names=(cornell cornell-specular meshes-sky lights-plastic)
bench_candela
bash "$root/bench/references.sh" "${names[@]}"
scenes=()
for n in "${names[@]}"; do scenes+=("$root/bench/scenes/$n.xml:$root/bench/reference/$n.pfm"); done
export DRJIT_LIBLLVM_PATH=${DRJIT_LIBLLVM_PATH:-/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1}
bench_cpu
"$venv/bin/python" "$bench/efficiency.py" "$CANDELA_BIN" --scenes "${scenes[@]}" --spp 64 --res 512 \
  "${extra[@]}"
