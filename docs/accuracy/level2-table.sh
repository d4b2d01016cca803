#!/usr/bin/env bash
# CMLT's defaults against plain MLT on every scene of tests/scenes, equal
# wall time on 2 threads, several seeds, the two methods taking turns
# (cmlt-bench convergence interleaves them): relMSE ratios per pixel, at
# 4x4 and 16x16-pixel blocks, and per CPU second.
#   docs/accuracy/level2-table.sh [seconds] [seeds]   (default 5 s, 3 seeds)
# Writes docs/accuracy/level2-table.log and level2-table-<scene>.csv.
set -euo pipefail
cd "$(dirname "$0")/../.."
T=${1:-5}
SEEDS=${2:-3}
cargo build --release -q -p cmlt-bench
BIN=target/release/cmlt-bench
OUT=docs/accuracy
: > $OUT/level2-table.log
# The large scenes at half their reference's resolution, the small ones at theirs.
for spec in "veach-ajar 160 90" "veach-bidir 128 128" "caustic-pool 48 48" "cornell-box 128 128" \
            "veach-mis 160 90" "glossy-room 48 48" "plastics 48 48" "rough-glass 48 48" \
            "principled 48 48" "envmap 48 48" "surface-detail 48 48" "lights-punctual 48 48"; do
  set -- $spec
  uptime | tee -a $OUT/level2-table.log
  $BIN convergence tests/scenes/$1/scene.xml --reference tests/scenes/$1/reference.exr \
    -D resx=$2 -D resy=$3 --methods "${METHODS:-mlt,cmlt}" --budgets "$T" \
    --threads 2 --seeds "$SEEDS" --seeds-up-to "$T" --csv $OUT/level2-table-$1.csv | tee -a $OUT/level2-table.log
done
