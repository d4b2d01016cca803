#!/usr/bin/env bash
# Are two `cmlt` builds' images bit-identical for a fixed seed? Renders each
# estimator (pt, bdpt, mlt, cmlt) on two shared scenes at 64x64 with sample
# or mutation budgets (a time budget would differ anyway), 2 threads, seed 7,
# with both binaries, and compares the EXRs byte for byte.
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
    for method in pt bdpt mlt cmlt; do
        args=(render "tests/scenes/$scene/scene.xml" -D resx=64 -D resy=64
              --method "$method" --threads 2 --seed 7 --quiet)
        case $method in
            pt|bdpt) args+=(--spp 4) ;;
            *) args+=(--mutations-per-pixel 4) ;;
        esac
        "$base" "${args[@]}" -o "$out/base-$scene-$method.exr" >/dev/null 2>&1
        "$new" "${args[@]}" -o "$out/new-$scene-$method.exr" >/dev/null 2>&1
        if cmp -s "$out/base-$scene-$method.exr" "$out/new-$scene-$method.exr"; then
            echo "$scene $method: identical"
        else
            echo "$scene $method: DIFFERENT"
            status=1
        fi
    done
done
exit $status
