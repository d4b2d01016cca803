#!/usr/bin/env bash
# relMSE, samples/s and Mrays/s of PT and BDPT on each shared scene after
# 30 s on 2 threads.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -p cmlt-cli
for scene in cornell-box veach-mis veach-bidir veach-ajar; do
  for method in pt bdpt; do
    printf '%-12s %-5s ' "$scene" "$method"
    ./target/release/cmlt render "tests/scenes/$scene/scene.xml" --method "$method" --time "${SECS:-30}" --threads 2 --quiet \
      -o "target/30s-$scene-$method.exr" --reference "tests/scenes/$scene/reference.exr" 2>/dev/null | tr '\n' ' '
    echo
  done
done
