#!/usr/bin/env bash
# Regenerates the peer comparison and the parameter grid of docs/accuracy.md
# (about 19 minutes on 2 busy cores; progress on stdout):
#  1. our methods' error-vs-time curves on veach-bidir (128x128) and
#     veach-ajar (160x90), half the references' resolution, 2 threads:
#     <scene>.csv (replaced);
#  2. CMLT's σ × k × m grid on veach-bidir: params-veach-bidir.csv/.png/.svg;
#  3. the peers (bench/peers/run_peers.sh: Mitsuba 3, LuxCore) appended to
#     the same CSVs, and the plots <scene>.png/.svg drawn from them, with
#     <scene>-summary.txt (the curves and the times to reach LuxCore
#     METROPOLIS's error at 30 s).
set -euo pipefail
cd "$(dirname "$0")/../.."
cargo build --release -q -p cmlt-bench
BIN=target/release/cmlt-bench
OUT=docs/accuracy
BUDGETS=${BUDGETS:-1,2,4,8,15,30}
for spec in "veach-bidir 128 128" "veach-ajar 160 90"; do
  set -- $spec
  $BIN convergence tests/scenes/$1/scene.xml --reference tests/scenes/$1/reference.exr \
    -D resx=$2 -D resy=$3 --methods pt,bdpt,mlt,cmlt --budgets "$BUDGETS" \
    --threads 2 --seeds 2 --seeds-up-to 2 --csv $OUT/$1.csv --plot $OUT/$1
done
$BIN params tests/scenes/veach-bidir/scene.xml --reference tests/scenes/veach-bidir/reference.exr \
  -D resx=128 -D resy=128 --time 8 --lens-sigmas 1,2,8 --ks 1,4,16 --ms 1,4 \
  --threads 2 --csv $OUT/params-veach-bidir.csv --plot $OUT/params-veach-bidir
BIDIR_BUDGETS=${BIDIR_BUDGETS:-4,30} bench/peers/run_peers.sh $OUT
