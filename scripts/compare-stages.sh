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
. "$(dirname "$0")/bench-common.sh"
bench_args "$@"
scenes=("${args[@]}")
[ ${#scenes[@]} -gt 0 ] || scenes=("$root"/bench/scenes/*.xml)
bench_candela
bench_env
"$venv/bin/python" "$root/bench/stages.py" "$CANDELA_BIN" "${scenes[@]}" "${extra[@]}"
