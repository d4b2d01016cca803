#!/usr/bin/env bash
# Equal-time comparison of CMLT, MLT (k = m = 1 is the same code with
# level 2 off) and BDPT, and a small σ × k × m study. Prints one CSV row
# per run: scene,method,k,m,sigma,seconds,relmse,mean_ratio_g
#   bench/cmlt_study.sh [seconds] [threads]
set -euo pipefail
cd "$(dirname "$0")/.."
T=${1:-20}
THREADS=${2:-2}
cargo build --release -q -p cmlt-cli
BIN=target/release/cmlt
run() { # scene w h method extra...
  local scene=$1 w=$2 h=$3 method=$4; shift 4
  local out
  out=$($BIN render tests/scenes/$scene/scene.xml -D resx=$w -D resy=$h --method $method \
        --time "$T" --threads "$THREADS" --quiet -o /tmp/cmlt-study.exr \
        --reference tests/scenes/$scene/reference.exr "$@" 2>/dev/null | grep "vs reference")
  local rel ratio
  rel=$(sed -E 's/.*relMSE ([0-9.e-]+).*/\1/' <<<"$out")
  ratio=$(sed -E 's/.*mean ratio \([0-9.]+, ([0-9.]+).*/\1/' <<<"$out")
  echo "$scene,$method,$*,$T,$rel,$ratio"
}
echo "scene,method,params,seconds,relmse,mean_ratio_g"
MODE=${MODE:-compare}
if [ "$MODE" = compare ]; then
  for s in "veach-bidir 128 128" "veach-ajar 160 90"; do
    set -- $s
    run $1 $2 $3 bdpt
    run $1 $2 $3 mlt
    run $1 $2 $3 cmlt
  done
else
  for sigma in 2 8; do for k in 1 4 8 16; do for m in 1 4; do
    run veach-bidir 128 128 cmlt --k $k --m $m --lens-sigma $sigma
  done; done; done
fi
