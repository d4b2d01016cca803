#!/usr/bin/env bash
# Instructions and mispredicted conditional branches spent tracing one ray
# set of `cmlt-bench rays`, per kernel, counted by callgrind: the same
# counts on every run of the same binary, unlike throughput on a shared
# machine, so a kernel change can be compared by counts where timings are
# noise.
#
# Counts are not time. Cache misses cost nothing here. The branch
# predictor is callgrind's simple model, indexed by address: a change of
# code layout alone moves it by a few percent, and it mispredicts patterns
# that real predictors learn (a branch-free one-or-two-children step that
# cut its mispredictions on the mesh by 40%, at 9% more instructions,
# traced no faster on the machine). Valgrind runs no AVX-512, so
# `ours-packet*` run the AVX2 kernel and Embree its AVX2 code.
#
#   bench/rays_instructions.sh SCENE SET KERNEL... [-- extra bench args]
#   bench/rays_instructions.sh mesh diffuse ours-avx2 embree-1
#
# Prints, per kernel, the instructions and conditional-branch
# mispredictions of one pass over the set, each with its ratio to the first
# kernel's. Needs valgrind; builds with `--features embree` when an
# `embree-*` kernel is asked for.
set -euo pipefail
cd "$(dirname "$0")/.."
[ $# -ge 3 ] || { sed -n 2,22p "$0"; exit 2; }
scene=$1; set=$2; shift 2
kernels=(); while [ $# -gt 0 ] && [ "$1" != "--" ]; do kernels+=("$1"); shift; done
[ "${1:-}" = "--" ] && shift
features=()
for k in "${kernels[@]}"; do [[ $k == embree-* ]] && features=(--features embree); done
cargo build --release -q -p cmlt-bench "${features[@]}"
first=""; first_m=""
for k in "${kernels[@]}"; do
  # One pass (`--time 0`), one thread; only `trace` (the timed loop) counts.
  # Callgrind's summary: Ir Bc Bcm Bi Bim.
  read -r n m < <(valgrind --tool=callgrind --branch-sim=yes --callgrind-out-file=/dev/null \
        --toggle-collect='cmlt_cli::bench::rays::trace*' \
        ./target/release/cmlt-bench rays --scenes "$scene" --sets "$set" --kernels "$k" \
        --threads 1 --time 0 "$@" 2>&1 >/dev/null \
        | sed -n 's/.*Collected : \([0-9]*\) [0-9]* \([0-9]*\) .*/\1 \2/p')
  [ -n "${n:-}" ] || { echo "no count for $k" >&2; exit 1; }
  [ -n "$first" ] || { first=$n; first_m=$m; }
  printf '%-16s %14d instructions %6.3f  %10d mispredictions %6.3f\n' \
    "$k" "$n" "$(echo "$n / $first" | bc -l)" "$m" "$(echo "$m / $first_m" | bc -l)"
done
