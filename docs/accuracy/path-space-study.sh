#!/usr/bin/env bash
# The seed's experiment (Segovia 2007, §2.5) over the path-space level 1:
# path-space CMLT against path-space MLT, path-space MLT without its
# level-1 perturbations (perturb=0), and path-space MLT against the
# primary-sample MLT, at equal wall time on 2 threads, on veach-ajar,
# veach-bidir and caustic-pool (reduced resolutions), relMSE on pixels and
# on 4×4 and 16×16 blocks. The methods take turns at every seed (cmlt-bench
# convergence interleaves them), so the machine's load falls on all alike.
# The first method is the base of the printed ratios.
#   docs/accuracy/path-space-study.sh [seconds] [seeds]   (default 8 s, 3 seeds)
# Writes docs/accuracy/$NAME-<scene>.csv and .log (NAME path-space-study).
# METHODS, SCENES ("scene width height" triples, ';'-separated), NAME and
# BUDGETS (comma-separated seconds, ascending; default the one budget T)
# make other studies of the same form (path-space-params.sh and
# twelve-scenes.sh are two). Every budget renders every seed. EXTRA adds
# options to cmlt-bench convergence (e.g. --samples: budgets in
# mutations or samples per pixel).
set -euo pipefail
cd "$(dirname "$0")/../.."
T=${1:-8}
SEEDS=${2:-3}
cargo build --release -q -p cmlt-bench
BIN=${BIN:-target/release/cmlt-bench}
OUT=${OUT:-docs/accuracy}
METHODS=${METHODS:-mlt:level1=path,mlt:level1=path:perturb=0,cmlt:level1=path,cmlt:level1=path:depth=0,mlt}
NAME=${NAME:-path-space-study}
SCENES=${SCENES:-veach-ajar 160 90;veach-bidir 128 128;caustic-pool 48 48}
BUDGETS=${BUDGETS:-$T}
IFS=';' read -r -a SPECS <<<"$SCENES"
for spec in "${SPECS[@]}"; do
  set -- $spec
  # The load before and after each scene goes into its log: the figures
  # depend on it.
  uptime | tee $OUT/$NAME-$1.log
  $BIN convergence tests/scenes/$1/scene.xml --reference tests/scenes/$1/reference.exr \
    -D resx=$2 -D resy=$3 --methods "$METHODS" --budgets "$BUDGETS" \
    --threads 2 --seeds "$SEEDS" --seeds-up-to "${BUDGETS##*,}" --csv $OUT/$NAME-$1.csv ${EXTRA:-} | tee -a $OUT/$NAME-$1.log
  uptime | tee -a $OUT/$NAME-$1.log
done
