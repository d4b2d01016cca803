#!/usr/bin/env bash
# Segovia 2007's §2.5.1 parameter study (σ × m × k) redone for CMLT over
# the path-space level 1: path-space CMLT with side chains on every path
# (depth=0) at lens σ 2 and 8 pixels, k 1 and 4 candidates, m 1 and 4
# side-chain steps, against path-space MLT (the first method, the base of
# the printed ratios), at equal wall time on 2 threads, on veach-bidir and
# caustic-pool (reduced resolutions). The methods take turns at every seed
# (cmlt-bench convergence interleaves them), so the machine's load falls
# on all alike.
#   docs/accuracy/path-space-params.sh [seconds] [seeds]   (default 6 s, 2 seeds)
# Writes docs/accuracy/path-space-params-<scene>.csv and .log.
set -euo pipefail
cd "$(dirname "$0")/../.."
T=${1:-6}
SEEDS=${2:-2}
cargo build --release -q -p cmlt-bench
BIN=${BIN:-target/release/cmlt-bench}
OUT=${OUT:-docs/accuracy}
METHODS=mlt:level1=path
for s in 2 8; do for k in 1 4; do for m in 1 4; do
  METHODS=$METHODS,cmlt:level1=path:depth=0:sigma=$s:k=$k:m=$m
done; done; done
for spec in "veach-bidir 128 128" "caustic-pool 48 48"; do
  set -- $spec
  $BIN convergence tests/scenes/$1/scene.xml --reference tests/scenes/$1/reference.exr \
    -D resx=$2 -D resy=$3 --methods "$METHODS" --budgets "$T" \
    --threads 2 --seeds "$SEEDS" --seeds-up-to "$T" --csv $OUT/path-space-params-$1.csv | tee $OUT/path-space-params-$1.log
done
