#!/bin/sh
# Runs every cargo-fuzz target of fuzz/ for SECONDS seconds each (default 60) and prints, per
# target, the executions and whether it crashed. Needs nightly Rust and cargo-fuzz
# (`cargo install cargo-fuzz`). Seeds come from fuzz/seeds/<target>/; the growing corpora go to
# fuzz/corpus/<target>/ and crashing inputs to fuzz/artifacts/<target>/ (both ignored by git;
# a crash becomes a row of crates/cli/tests/bad_input/cases.txt once fixed).
#
#   scripts/fuzz.sh 120
#   TARGETS="obj ply" scripts/fuzz.sh 30
#   RUNS=100000 scripts/fuzz.sh 900    # stop each target after 10^5 executions (or 900 s)
set -u
secs=${1:-60}
cd "$(dirname "$0")/../fuzz" || exit 1
targets=${TARGETS:-"parse_scene mitsuba_xml obj ply pfm exr hdr png radiosity_cache"}
cargo +nightly fuzz build -O || exit 1
mkdir -p logs
status=0
summary=""
for t in $targets; do
    mkdir -p "corpus/$t" "seeds/$t"
    dict=""
    [ "$t" = parse_scene ] && dict="-dict=parse_scene.dict"
    runs_opt=""
    [ -n "${RUNS:-}" ] && runs_opt="-runs=$RUNS"
    cargo +nightly fuzz run -O "$t" "corpus/$t" "seeds/$t" -- \
        -max_total_time="$secs" -rss_limit_mb=1024 -malloc_limit_mb=1024 -timeout=10 \
        -print_final_stats=1 $runs_opt $dict >"logs/$t.log" 2>&1
    rc=$?
    runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "logs/$t.log" | grep -o '[0-9]*$' | tail -1)
    if [ $rc -ne 0 ]; then
        status=1
        result="CRASH (see logs/$t.log, artifacts/$t/)"
    else
        result="ok"
    fi
    line=$(printf '%-16s %12s executions  %s' "$t" "${runs:-?}" "$result")
    echo "$line"
    summary="$summary$line\n"
done
printf '\n%b' "$summary"
exit $status
