# Shared by the bench scripts (compare-mitsuba.sh, compare-variants.sh, compare-stages.sh):
# sourced, never run. Sets `root` and `venv`; `bench_args "$@"` splits the arguments into
# `args` (before `--`) and `extra` (after it); `bench_candela` builds candela unless
# CANDELA_BIN names a binary, and sets CANDELA_BIN; `bench_env` checks the bench's virtual
# environment and the meshes and sets the LLVM library Mitsuba's JIT loads.
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
venv=${CANDELA_BENCH_VENV:-$HOME/.cache/candela-bench/venv}

bench_args() {
  args=(); extra=()
  while [ $# -gt 0 ]; do
    if [ "$1" = "--" ]; then shift; extra=("$@"); break; fi
    args+=("$1"); shift
  done
}

bench_candela() {
  if [ -z "${CANDELA_BIN:-}" ]; then
    (cd "$root" && cargo build --release -q)
    CANDELA_BIN=$root/target/release/candela
  fi
}

bench_env() {
  [ -x "$venv/bin/python" ] || { echo "no bench environment at $venv: run scripts/compare-mitsuba.sh once" >&2; exit 1; }
  [ -f "$root/bench/meshes/sky.pfm" ] || python3 "$root/bench/make-meshes.py"
  export DRJIT_LIBLLVM_PATH=${DRJIT_LIBLLVM_PATH:-/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1}
}

bench_cpu() {
  echo "CPU: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs); $(nproc) cores;" \
    "AVX-512: $(grep -qw avx512f /proc/cpuinfo && echo yes || echo no)"
}
