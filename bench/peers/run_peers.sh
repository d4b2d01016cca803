#!/usr/bin/env bash
# Peer renderers' curves next to ours: Mitsuba 3 (scalar_rgb, path) and
# LuxCoreRender 2.11.2 (PATHCPU + METROPOLIS; BIDIRCPU + METROPOLIS, which is
# biased, see docs/accuracy.md) render the shared scenes at the same
# resolution, budgets and thread count as `cmlt-bench convergence`; every
# render is scored by `cmlt-bench score` against the same reference and
# appended to the same CSV, then `cmlt-bench plot` redraws the plot and
# prints how long each method takes to reach LuxCore METROPOLIS's error at
# 30 s.
#
#   bench/peers/run_peers.sh [OUTDIR]     (default docs/accuracy)
#
# Environment: PEER_BUDGETS (2,4,8,15,30), BIDIR_BUDGETS (4,15,30),
# THREADS (2), VERSUS_AT (30; empty: no comparison), SCENES ("veach-bidir:128:128 veach-ajar:160:90"),
# CHECK_SEEDS (0; n > 0 first checks the conversion: `peers.py check`, n
# renders of CHECK_TIME (30) s with PATHCPU + RANDOM on 1 thread, image
# means against the reference's, written to OUTDIR/<scene>-luxcore-check.txt;
# 8 seeds take about 4.5 minutes per scene), PEERS ("mitsuba luxcore
# luxcore-bidir": which curves to render; a curve rendered again replaces
# its rows in the CSV, the others are kept).
# Creates bench/peers/.venv (pyluxcore, mitsuba, numpy from PyPI) on first
# use. Each render runs in a process of its own: pyluxcore and mitsuba crash
# when imported into one process.
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
cd "$ROOT"
OUT=${1:-docs/accuracy}
PEER_BUDGETS=${PEER_BUDGETS:-2,4,8,15,30}
BIDIR_BUDGETS=${BIDIR_BUDGETS:-4,15,30}
THREADS=${THREADS:-2}
VERSUS_AT=${VERSUS_AT-30}
SCENES=${SCENES:-"veach-bidir:128:128 veach-ajar:160:90"}
CHECK_SEEDS=${CHECK_SEEDS:-0}
CHECK_TIME=${CHECK_TIME:-30}
PEERS=${PEERS:-"mitsuba luxcore luxcore-bidir"}
VENV=bench/peers/.venv
PY=$VENV/bin/python
WORK=bench/peers/work
if [ ! -x "$PY" ]; then
  python3 -m venv "$VENV"
  "$VENV/bin/pip" install -q pyluxcore==2.11.2 mitsuba==3.9.1 numpy
fi
cargo build --release -q -p cmlt-bench
BIN=target/release/cmlt-bench
mkdir -p "$WORK" "$OUT"

# score SCENE METHOD BUDGET IMAGE "RESULT wall spp" CSV
score() {
  local scene=$1 method=$2 budget=$3 img=$4 result=$5 csv=$6
  read -r _ wall spp <<<"$result"
  "$BIN" score "$img" --reference "tests/scenes/$scene/reference.exr" --method "$method" \
    --budget-s "$budget" --wall-s "$wall" --samples "$spp" --csv "$csv"
}

for spec in $SCENES; do
  IFS=: read -r scene w h <<<"$spec"
  xml=tests/scenes/$scene/scene.xml
  csv=$OUT/$scene.csv
  lux=$WORK/$scene-${w}x$h
  if [ "$CHECK_SEEDS" -gt 0 ]; then
    { echo "# bench/peers/peers.py check $xml --reference tests/scenes/$scene/reference.exr --resx $w --resy $h --time $CHECK_TIME --seeds $CHECK_SEEDS --threads 1 --sampler RANDOM"
      "$PY" bench/peers/peers.py check "$xml" --reference "tests/scenes/$scene/reference.exr" --resx "$w" --resy "$h" \
        --time "$CHECK_TIME" --seeds "$CHECK_SEEDS" --threads 1 --sampler RANDOM; } | tee "$OUT/$scene-luxcore-check.txt"
  fi
  "$PY" bench/peers/peers.py convert "$xml" "$lux" --resx "$w" --resy "$h"
  has() { [[ " $PEERS " == *" $1 "* ]]; }
  drop() { if [ -f "$csv" ]; then grep -v "^$1," "$csv" > "$csv.tmp" || true; mv "$csv.tmp" "$csv"; fi; }
  if has mitsuba; then drop mitsuba-path; fi
  if has luxcore; then drop luxcore-metropolis-path; fi
  if has luxcore-bidir; then drop luxcore-bidir; fi
  for b in ${PEER_BUDGETS//,/ }; do
    if has mitsuba; then
      img=$WORK/$scene-mitsuba-$b.exr
      r=$("$PY" bench/peers/peers.py mitsuba "$xml" "$img" --resx "$w" --resy "$h" --time "$b" --threads "$THREADS" | grep RESULT)
      score "$scene" mitsuba-path "$b" "$img" "$r" "$csv"
    fi
    if has luxcore; then
      img=$WORK/$scene-luxcore-metropolis-$b.exr
      r=$("$PY" bench/peers/peers.py luxcore "$lux/scene.scn" "$img" --resx "$w" --resy "$h" --time "$b" \
          --threads "$THREADS" --engine PATHCPU --sampler METROPOLIS 2>/dev/null | grep RESULT)
      score "$scene" luxcore-metropolis-path "$b" "$img" "$r" "$csv"
    fi
  done
  has luxcore-bidir || BIDIR_BUDGETS=""
  for b in ${BIDIR_BUDGETS//,/ }; do
    img=$WORK/$scene-luxcore-bidir-$b.exr
    r=$("$PY" bench/peers/peers.py luxcore "$lux/scene.scn" "$img" --resx "$w" --resy "$h" --time "$b" \
        --threads "$THREADS" --engine BIDIRCPU --sampler METROPOLIS 2>/dev/null | grep RESULT)
    score "$scene" luxcore-bidir "$b" "$img" "$r" "$csv"
  done
  versus=()
  if [ -n "$VERSUS_AT" ]; then versus=(--versus luxcore-metropolis-path --at "$VERSUS_AT"); fi
  "$BIN" plot --csv "$csv" --plot "$OUT/$scene" --title "$scene (${w}x$h, $THREADS threads)" \
    --reference "tests/scenes/$scene/reference.exr" "${versus[@]}" | tee "$OUT/$scene-summary.txt"
done
