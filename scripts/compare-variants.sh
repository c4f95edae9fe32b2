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
. "$(dirname "$0")/bench-common.sh"
bench_args "$@"
scenes=("${args[@]}")
[ ${#scenes[@]} -gt 0 ] || scenes=("$root"/bench/extra/*.xml)
bench_candela
bench_env
bench_cpu
"$venv/bin/python" "$root/bench/seed-variance.py" "$CANDELA_BIN" "${scenes[@]}" "${extra[@]}"
