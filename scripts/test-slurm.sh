#!/usr/bin/env bash
# End-to-end test of the Slurm recipe (contrib/slurm/): starts a single-node Slurm on this
# machine (munge, slurmctld and slurmd, no systemd), submits a frame split into sample ranges
# as a job array plus the dependent merge, and an animation as an array of frames, waits,
# and compares the bytes with local renders. Stops the daemons it started. Exit 0 when the
# bytes agree.
#
# Needs root (for munge and slurmd) and Debian's slurm-wlm and munge packages; installs them
# with apt-get when they are missing. CANDELA_BIN=path skips the build.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
if ! command -v slurmctld >/dev/null || ! command -v munged >/dev/null; then
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq slurm-wlm munge >/dev/null
fi
if [ -z "${CANDELA_BIN:-}" ]; then
  (cd "$root" && cargo build --release -q)
  CANDELA_BIN=$root/target/release/candela
fi
export CANDELA=$CANDELA_BIN

tmp=$(mktemp -d /tmp/candela-slurm.XXXXXX)
chmod 755 "$tmp"
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  sleep 0.5
  for p in "${pids[@]}"; do kill -9 "$p" 2>/dev/null || true; done
  if [ "${KEEP:-0}" = 1 ]; then echo "kept $tmp"; else rm -rf "$tmp"; fi
}
trap cleanup EXIT

# munge: its own key, socket and state in $tmp (not the system's).
mkdir -p "$tmp/munge"/{etc,run,log,lib}
chmod 700 "$tmp/munge"/{etc,lib,log}
mungekey --create --keyfile="$tmp/munge/etc/munge.key" 2>/dev/null ||
  dd if=/dev/urandom bs=1 count=1024 of="$tmp/munge/etc/munge.key" status=none
chmod 400 "$tmp/munge/etc/munge.key"
socket=$tmp/munge/run/munge.socket
munged --force --key-file="$tmp/munge/etc/munge.key" --socket="$socket" \
  --pid-file="$tmp/munge/run/munged.pid" --log-file="$tmp/munge/log/munged.log" \
  --seed-file="$tmp/munge/lib/munged.seed"
for _ in $(seq 50); do [ -f "$tmp/munge/run/munged.pid" ] && break; sleep 0.1; done
pids+=("$(cat "$tmp/munge/run/munged.pid")")

# Slurm: one node, this machine, every core.
host=$(hostname -s)
mkdir -p "$tmp/slurm"/{state,spool,log}
conf=$tmp/slurm/slurm.conf
cat > "$conf" <<CONF
ClusterName=candela-test
SlurmctldHost=$host
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$socket
CredType=cred/munge
StateSaveLocation=$tmp/slurm/state
SlurmdSpoolDir=$tmp/slurm/spool
SlurmctldPidFile=$tmp/slurm/slurmctld.pid
SlurmdPidFile=$tmp/slurm/slurmd.pid
SlurmctldLogFile=$tmp/slurm/log/slurmctld.log
SlurmdLogFile=$tmp/slurm/log/slurmd.log
SlurmctldPort=${SLURMCTLD_PORT:-16817}
SlurmdPort=${SLURMD_PORT:-16818}
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
MpiDefault=none
ReturnToService=2
SlurmctldTimeout=30
SlurmdTimeout=30
InactiveLimit=0
KillWait=5
NodeName=$host CPUs=$(nproc) State=UNKNOWN
PartitionName=test Nodes=$host Default=YES MaxTime=INFINITE State=UP OverSubscribe=YES
CONF
export SLURM_CONF=$conf
slurmctld -f "$conf" -i
for _ in $(seq 100); do [ -f "$tmp/slurm/slurmctld.pid" ] && break; sleep 0.1; done
pids+=("$(cat "$tmp/slurm/slurmctld.pid")")
slurmd -f "$conf"
for _ in $(seq 100); do [ -f "$tmp/slurm/slurmd.pid" ] && break; sleep 0.1; done
pids+=("$(cat "$tmp/slurm/slurmd.pid")")
for i in $(seq 150); do
  if sinfo -h -o '%T' 2>/dev/null | grep -qE '^(idle|mixed|allocated)'; then break; fi
  if [ "$i" = 150 ]; then
    echo "test-slurm: the node never came up" >&2
    sinfo >&2 || true
    tail -20 "$tmp/slurm/log/slurmctld.log" "$tmp/slurm/log/slurmd.log" >&2 || true
    exit 1
  fi
  scontrol update nodename="$host" state=resume >/dev/null 2>&1 || true
  sleep 0.2
done

wait_jobs() {
  for _ in $(seq 600); do
    [ -z "$(squeue -h -o '%i' 2>/dev/null)" ] && return 0
    sleep 0.5
  done
  echo "test-slurm: jobs still queued after 5 minutes" >&2
  squeue >&2
  return 1
}

scene=$root/examples/course-demo.scene
opts=(--width 96 --height 64)
cd "$tmp"

# One frame in 4 sample ranges, merged by a dependent job.
WORK=$tmp/frame SBATCH_OPTS="--cpus-per-task=1" \
  bash "$root/contrib/slurm/submit.sh" "$scene" "$tmp/farm.pfm" 32 4 "${opts[@]}" -d clock=45 \
  >"$tmp/submit.out"
wait_jobs
"$CANDELA" render "$scene" --spp 32 "${opts[@]}" -d clock=45 -o "$tmp/local.pfm" -q
status=0
if [ -f "$tmp/farm.pfm" ] && cmp -s "$tmp/farm.pfm" "$tmp/local.pfm"; then
  echo "test-slurm: 4 array tasks + merge == one local render (bytes equal)"
else
  echo "test-slurm: the merged frame differs from the local render (or is missing)" >&2
  cat "$tmp"/frame/*.log >&2 || true
  status=1
fi

# An animation: one array task per frame.
FRAMES=10..13 WORK=$tmp/anim SBATCH_OPTS="--cpus-per-task=1" \
  bash "$root/contrib/slurm/submit.sh" "$scene" "$tmp/anim_%04d.png" 4 1 "${opts[@]}" \
  >>"$tmp/submit.out"
wait_jobs
for f in 10 11 12; do
  "$CANDELA" render "$scene" --spp 4 "${opts[@]}" -d clock=$f -o "$tmp/local_$f.png" -q
  if ! cmp -s "$tmp/anim_00$f.png" "$tmp/local_$f.png"; then
    echo "test-slurm: frame $f differs from the local render (or is missing)" >&2
    cat "$tmp"/anim/*.log >&2 || true
    status=1
  fi
done
[ $status = 0 ] && echo "test-slurm: 3 frames as array tasks == local renders (bytes equal)"
exit $status
