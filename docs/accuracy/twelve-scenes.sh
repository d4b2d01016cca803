#!/usr/bin/env bash
# Every estimator of issues 51 and 53 on the twelve surface scenes of
# tests/scenes (media-fog and media-glass are path-traced only): BDPT,
# primary-sample MLT, path-space MLT and path-space CMLT at two budgets,
# T and 4T seconds, on 2 threads, the methods taking turns at every seed.
# Sizes as level2-table.sh's: the large scenes at half their reference's
# resolution, the small ones at theirs.
#   docs/accuracy/twelve-scenes.sh [T seconds] [seeds]   (default 3 s, 2 seeds)
# (SKIP_RENDERS=1 skips the equal-time runs, SKIP_MPP=1 the per-mutation
# ones.)
# Writes docs/accuracy/twelve-scenes-<scene>.csv and .log (through
# path-space-study.sh, with these methods, scenes and budgets), the same
# for the chains alone per mutation (twelve-scenes-mpp-*, below) and
# twelve-scenes-reference.csv (each reference's channel means: the
# reference scored against itself); then
#   python3 docs/accuracy/twelve-scenes-table.py
# prints the two tables of docs/accuracy.md from the CSVs.
set -euo pipefail
T=${1:-3}
SCENES="veach-ajar 160 90;veach-bidir 128 128;caustic-pool 48 48;cornell-box 128 128;\
veach-mis 160 90;glossy-room 48 48;plastics 48 48;rough-glass 48 48;\
principled 48 48;envmap 48 48;surface-detail 48 48;lights-punctual 48 48"
if [ -z "${SKIP_RENDERS:-}" ]; then
  METHODS=bdpt,mlt,mlt:level1=path,cmlt:level1=path BUDGETS=$T,$((4 * T)) \
    NAME=twelve-scenes SCENES="$SCENES" "$(dirname "$0")/path-space-study.sh" "$T" "${2:-2}"
fi
# The chains alone per mutation (no passes' image, whose fixed weight makes
# a combined image's error fall slower than 1/t while it is a large part
# of it): 16 and 64 mutations per pixel, deterministic, so the load does
# not enter. Writes twelve-scenes-mpp-<scene>.csv and .log.
if [ -z "${SKIP_MPP:-}" ]; then
  METHODS=mlt:pass_records=0,mlt:level1=path:pass_records=0,cmlt:level1=path:pass_records=0 \
    BUDGETS=16,64 EXTRA=--samples NAME=twelve-scenes-mpp SCENES="$SCENES" \
    "$(dirname "$0")/path-space-study.sh" "$T" "${2:-2}"
fi
cd "$(dirname "$0")/../.."
REF=docs/accuracy/twelve-scenes-reference.csv
rm -f $REF
IFS=';' read -r -a SPECS <<<"$SCENES"
for spec in "${SPECS[@]}"; do
  set -- $spec
  target/release/cmlt-bench score tests/scenes/$1/reference.exr --reference tests/scenes/$1/reference.exr \
    --method $1 --wall-s 0 --csv $REF >/dev/null
done
