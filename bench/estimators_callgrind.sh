#!/usr/bin/env bash
# Instructions per sample (PT, BDPT) and per mutation (MLT, CMLT) of two
# `cmlt` builds on the shared scenes, counted by callgrind: the same count
# on every run of a binary, unlike throughput on a shared machine.
#
#   bench/estimators_callgrind.sh OLD NEW [SCENES] [METHODS] [OUTDIR]
#   bench/estimators_callgrind.sh /tmp/cmlt-old target/release/cmlt \
#       cornell-box,veach-mis,veach-bidir,veach-ajar pt,bdpt,mlt,cmlt
#
# Each case renders twice per binary, 32x32, one thread, seed 3, with a low
# and a high budget (PT/BDPT 1 and 3 samples per pixel, MLT/CMLT 4 and 12
# mutations per pixel, bootstrap 200): the difference of the two counts
# divided by the extra samples or mutations is the cost of one, with the
# loading, the BVH build, the bootstrap and the normalisation passes
# cancelled (they do not depend on the budget). Prints per case both costs
# and NEW / OLD (< 1: NEW does less work). The callgrind files stay in
# OUTDIR (default: a new temporary directory, printed) for
# `callgrind_annotate`. Scenes are read from `tests/scenes` of the current
# directory; run from the repository root. Needs valgrind.
set -euo pipefail
[ $# -ge 2 ] || { sed -n 2,19p "$0"; exit 2; }
old=$1
new=$2
scenes=${3:-cornell-box,veach-mis,veach-bidir,veach-ajar}
methods=${4:-pt,bdpt,mlt,cmlt}
out=${5:-$(mktemp -d /tmp/estimators_callgrind.XXXXXX)}
mkdir -p "$out"
echo "callgrind files in $out"

# Budget flags of method $1 at level $2 (lo or hi), and the units per pixel
# between the two levels.
budget() {
    case $1/$2 in
        pt/lo | bdpt/lo) echo "--spp 1" ;;
        pt/hi | bdpt/hi) echo "--spp 3" ;;
        */lo) echo "--mutations-per-pixel 4 --bootstrap 200" ;;
        */hi) echo "--mutations-per-pixel 12 --bootstrap 200" ;;
    esac
}
extra_per_pixel() {
    case $1 in pt | bdpt) echo 2 ;; *) echo 8 ;; esac
}

# Instructions of one render (callgrind's "Collected" total). With
# OLD_CG=DIR the OLD binary's counts are read from an earlier run's files
# in DIR instead of being counted again.
count() {
    local bin=$1 scene=$2 method=$3 level=$4 tag=$5
    local file="$out/$tag-$scene-$method-$level.cg"
    if [ $tag = old ] && [ -n "${OLD_CG:-}" ]; then
        sed -n 's/^totals: \([0-9]*\).*/\1/p' "$OLD_CG/$tag-$scene-$method-$level.cg"
        return
    fi
    # shellcheck disable=SC2046
    valgrind --tool=callgrind --callgrind-out-file="$file" \
        "$bin" render "tests/scenes/$scene/scene.xml" -D resx=32 -D resy=32 \
        --method "$method" $(budget "$method" "$level") --threads 1 --seed 3 \
        --quiet -o "$out/$tag-$scene-$method-$level.exr" 2>&1 >/dev/null |
        sed -n 's/.*Collected : \([0-9]*\).*/\1/p'
}

printf '%-12s %-5s %14s %14s %8s\n' scene method old_Ir/unit new_Ir/unit new/old
IFS=, read -r -a scene_list <<<"$scenes"
IFS=, read -r -a method_list <<<"$methods"
for scene in "${scene_list[@]}"; do
    for method in "${method_list[@]}"; do
        units=$((32 * 32 * $(extra_per_pixel "$method")))
        per=()
        for tag in old new; do
            bin=$old
            [ $tag = new ] && bin=$new
            lo=$(count "$bin" "$scene" "$method" lo $tag)
            hi=$(count "$bin" "$scene" "$method" hi $tag)
            [ -n "$lo" ] && [ -n "$hi" ] || { echo "no count: $tag $scene $method" >&2; exit 1; }
            per+=("$(echo "($hi - $lo) / $units" | bc -l)")
        done
        printf '%-12s %-5s %14.0f %14.0f %8.4f\n' "$scene" "$method" "${per[0]}" "${per[1]}" \
            "$(echo "${per[1]} / ${per[0]}" | bc -l)"
    done
done
