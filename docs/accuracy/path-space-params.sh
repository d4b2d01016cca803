#!/usr/bin/env bash
# Segovia 2007's §2.5.1 parameter study (σ × m × k) redone for CMLT over
# the path-space level 1: path-space CMLT with side chains on every path
# (depth=0) at lens σ 2 and 8 pixels, k 1 and 4 candidates, m 1 and 4
# side-chain steps, against path-space MLT (the first method, the base of
# the printed ratios), at equal wall time on 2 threads, on veach-bidir and
# caustic-pool (reduced resolutions). It runs path-space-study.sh with
# these methods and scenes, so the methods take turns at every seed in
# the same way.
#   docs/accuracy/path-space-params.sh [seconds] [seeds]   (default 6 s, 2 seeds)
# Writes docs/accuracy/path-space-params-<scene>.csv and .log.
set -euo pipefail
METHODS=mlt:level1=path
for s in 2 8; do for k in 1 4; do for m in 1 4; do
  METHODS=$METHODS,cmlt:level1=path:depth=0:sigma=$s:k=$k:m=$m
done; done; done
METHODS=$METHODS NAME=path-space-params SCENES="veach-bidir 128 128;caustic-pool 48 48" \
  exec "$(dirname "$0")/path-space-study.sh" "${1:-6}" "${2:-2}"
