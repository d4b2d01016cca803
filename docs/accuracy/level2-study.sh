#!/usr/bin/env bash
# CMLT's level-2 parameter study: a handful of settings against plain MLT,
# equal wall time, 2 threads, on the four scenes where level 2 should pay or
# must not cost. The methods take turns at every seed (cmlt-bench
# convergence interleaves them), so the machine's load falls on all alike.
#   docs/accuracy/level2-study.sh [seconds] [seeds]   (default 6 s, 2 seeds)
# Writes docs/accuracy/level2-study-<scene>.csv and .log.
set -euo pipefail
cd "$(dirname "$0")/../.."
T=${1:-6}
SEEDS=${2:-2}
cargo build --release -q -p cmlt-bench
BIN=target/release/cmlt-bench
OUT=docs/accuracy
METHODS=${METHODS:-mlt,cmlt:lanes=1:m=1:share=1:depth=0,cmlt:lanes=4:m=1:share=1,cmlt:lanes=4:m=1:share=4,cmlt:lanes=4:m=2:share=2,cmlt:lanes=4:m=1:share=1:depth=4,cmlt:lanes=8:m=1:share=2,cmlt:lanes=4:m=1:share=1:sigma=2}
for spec in "veach-ajar 160 90" "veach-bidir 128 128" "caustic-pool 48 48" "cornell-box 128 128"; do
  set -- $spec
  $BIN convergence tests/scenes/$1/scene.xml --reference tests/scenes/$1/reference.exr \
    -D resx=$2 -D resy=$3 --methods "$METHODS" --budgets "$T" \
    --threads 2 --seeds "$SEEDS" --seeds-up-to "$T" --csv $OUT/level2-study-$1.csv | tee $OUT/level2-study-$1.log
done
