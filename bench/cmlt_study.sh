#!/usr/bin/env bash
# Superseded by `cmlt-bench convergence` and `cmlt-bench params` (see
# docs/accuracy.md); kept so that old references to it still work.
#   bench/cmlt_study.sh [seconds] [threads]            equal-time BDPT/MLT/CMLT
#   MODE=study bench/cmlt_study.sh [seconds] [threads] σ × k × m grid on veach-bidir
# bench/cmlt_study_veach_bidir.csv is the output of the old shell version
# (the study MltSettings::cmlt()'s defaults cite).
set -euo pipefail
cd "$(dirname "$0")/.."
T=${1:-20}
THREADS=${2:-2}
cargo build --release -q -p cmlt-bench
BIN=target/release/cmlt-bench
if [ "${MODE:-compare}" = compare ]; then
  for s in "veach-bidir 128 128" "veach-ajar 160 90"; do
    set -- $s
    $BIN convergence tests/scenes/$1/scene.xml --reference tests/scenes/$1/reference.exr \
      -D resx=$2 -D resy=$3 --methods bdpt,mlt,cmlt --budgets "$T" --seeds 1 --threads "$THREADS"
  done
else
  $BIN params tests/scenes/veach-bidir/scene.xml --reference tests/scenes/veach-bidir/reference.exr \
    -D resx=128 -D resy=128 --time "$T" --lens-sigmas 2,8 --ks 1,4,8,16 --ms 1,4 --threads "$THREADS"
fi
