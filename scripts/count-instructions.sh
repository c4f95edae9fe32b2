#!/usr/bin/env bash
# Instructions per ray of candela's BVH and of Embree on the same rays, counted by Valgrind's
# callgrind (this machine has no hardware performance counters, and counts do not vary from run
# to run as times do).
#
# For each of the accelerator bench's bounce sets (first-bounce rays leaving a mesh, random
# rays through it: `accel_compare bounce`), one ray-by-ray pass of each structure runs under
# callgrind; the inclusive count of that pass (`single_pass`, `single_pass_embree`) over the
# number of rays is the instructions per ray (the traversal, the leaf tests and the call's
# setup, nothing else). Under Valgrind both run their AVX2 code (it reports no AVX-512).
#
# Usage: bash scripts/count-instructions.sh [SUBDIV] [RAYS]   (defaults 145 and 65536: a
# 250k-triangle mesh, so that the builds take seconds under Valgrind)
# Needs valgrind and libembree-dev (apt-get install valgrind libembree-dev).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
subdiv=${1:-145}
rays=${2:-65536}
target=${CARGO_TARGET_DIR:-$root/target}
(cd "$root" && cargo build --release -q -p candela-render --features embree --example accel_compare)
bin=$target/release/examples/accel_compare
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
for set in first random; do
  valgrind --tool=callgrind --callgrind-out-file="$out/$set" "$bin" bounce --subdiv "$subdiv" \
    --rays "$rays" --repeat 1 --bounce-set "$set" --accel bvh >"$out/$set.txt" 2>/dev/null
  n=$(sed -n 's/^== bounce: \([0-9]*\) .*/\1/p' "$out/$set.txt")
  callgrind_annotate --inclusive=yes "$out/$set" 2>/dev/null |
    awk -v set="$set" -v n="$n" '
      /accel_compare::single_pass_embree / { gsub(",", "", $1); e = $1 }
      /accel_compare::single_pass / { gsub(",", "", $1); b = $1 }
      END {
        if (b == "" || e == "" || n == "") { print set ": passes not found in the profile"; exit 1 }
        printf "%-7s rays: candela BVH %7.1f instructions/ray, Embree %7.1f  (%.2fx Embree'"'"'s; %d rays)\n",
          set, b / n, e / n, b / e, n
      }'
done
