#!/usr/bin/env bash
# Submits a candela render to Slurm as a job array (docs/farm.md).
#
#   submit.sh SCENE OUT SPP PARTS [CANDELA OPTIONS...]
#       one frame, split into PARTS sample ranges (PARTS ≤ SPP/4), then a dependent job that
#       merges them into OUT: the same bytes as one uninterrupted render
#   FRAMES=A..B submit.sh SCENE 'OUT_%04d.png' SPP 1 [CANDELA OPTIONS...]
#       an animation: one array task per frame (clock = frame number)
#
# Environment: CANDELA (the binary; default: candela on PATH), WORK (a folder every node sees;
# default ./candela-work), SBATCH_OPTS (more sbatch options, e.g. "--partition=render
# --cpus-per-task=8"). Prints the id of the last job submitted (the merge, or the array).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
[ $# -ge 4 ] || { sed -n '2,14p' "$0" >&2; exit 2; }
scene=$(realpath "$1"); out=$2; spp=$3; parts=$4; shift 4
candela=$(realpath "${CANDELA:-$(command -v candela)}")
work=$(realpath -m "${WORK:-candela-work}")
mkdir -p "$work"
case $out in /*) ;; *) out=$PWD/$out ;; esac
read -ra extra <<< "${SBATCH_OPTS:-}"
# The job's settings, for the batch scripts to source (values may hold spaces and commas).
env_file=$work/job.env
{
  printf 'CANDELA=%q\nSCENE=%q\nSPP=%q\nPARTS=%q\nWORK=%q\nOUT=%q\n' \
    "$candela" "$scene" "$spp" "$parts" "$work" "$out"
  printf 'OPTIONS=('; if [ $# -gt 0 ]; then printf '%q ' "$@"; fi; printf ')\n'
  if [ -n "${FRAMES:-}" ]; then printf 'FIRST=%q\n' "${FRAMES%..*}"; fi
} > "$env_file"
export JOBENV=$env_file
if [ -n "${FRAMES:-}" ]; then
  first=${FRAMES%..*}; last=${FRAMES#*..}
  sbatch --parsable "${extra[@]}" --array="0-$((last - first - 1))" \
    --output="$work/frame-%a.log" --export=ALL "$here/render-frame.sbatch"
  exit 0
fi
if [ "$parts" -lt 1 ] || [ $((parts * 4)) -gt "$spp" ]; then
  echo "submit.sh: PARTS must be between 1 and SPP/4" >&2; exit 2
fi
array=$(sbatch --parsable "${extra[@]}" --array="0-$((parts - 1))" --output="$work/part-%a.log" \
  --export=ALL "$here/render-part.sbatch")
sbatch --parsable "${extra[@]}" --dependency="afterok:${array%%;*}" --output="$work/merge.log" \
  --export=ALL "$here/merge.sbatch"
