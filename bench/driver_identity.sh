#!/usr/bin/env bash
# Are two `cmlt` builds' images bit-identical for a fixed seed? Renders each
# estimator (pt, bdpt, mlt, cmlt) on two shared scenes at 64x64 with sample
# or mutation budgets (a time budget would differ anyway), seed 7, on 2
# threads with 4 samples or mutations per pixel and on 3 threads with 5
# (shares of unequal size), with both binaries, and compares the EXRs byte
# for byte.
#
#   bench/driver_identity.sh BASE_BINARY [NEW_BINARY]
#
# NEW_BINARY defaults to target/release/cmlt. Exit status 0 when every pair
# is identical. Run from the repository's root.
set -euo pipefail
base=${1:?usage: $0 BASE_BINARY [NEW_BINARY]}
new=${2:-target/release/cmlt}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
status=0
for scene in cornell-box veach-bidir; do
    for run in "2 4" "3 5"; do
        read -r threads n <<<"$run"
        for method in pt bdpt mlt cmlt; do
            args=(render "tests/scenes/$scene/scene.xml" -D resx=64 -D resy=64
                  --method "$method" --threads "$threads" --seed 7 --quiet)
            case $method in
                pt|bdpt) args+=(--spp "$n") ;;
                *) args+=(--mutations-per-pixel "$n") ;;
            esac
            name="$scene-$method-$threads"
            "$base" "${args[@]}" -o "$out/base-$name.exr" >/dev/null 2>&1
            "$new" "${args[@]}" -o "$out/new-$name.exr" >/dev/null 2>&1
            if cmp -s "$out/base-$name.exr" "$out/new-$name.exr"; then
                echo "$scene $method, $threads threads, $n per pixel: identical"
            else
                echo "$scene $method, $threads threads, $n per pixel: DIFFERENT"
                status=1
            fi
        done
    done
done
exit $status
