#!/bin/sh
# Equal time on a tests/scenes scene: our MLT with large steps by MIS off and on, interleaved per seed.
#   CMLT=target/release/cmlt SCENE=veach-mis BUDGETS="10 30" SEEDS="1 2" sh scene_mis.sh  (OUT: scratch folder, /tmp)
R=${SCENES:-$(dirname "$0")/../../../tests/scenes}/$SCENE
for B in ${BUDGETS:-10}; do for seed in ${SEEDS:-1 2}; do for m in false true; do
  l=$(cut -d' ' -f1 /proc/loadavg)
  /usr/bin/time -f "%e %U %S" -o ${OUT:-/tmp}/t2.txt ${CMLT:?set CMLT to a cmlt binary} render $R/scene.xml --method mlt --threads 2 --seed $seed --time $B --large-step-mis $m --reference $R/reference.exr -o ${OUT:-/tmp}/sc_${SCENE}_${m}_${B}_$seed.exr --quiet > ${OUT:-/tmp}/l2.txt 2>&1
  echo "$SCENE mis=$m $B s$seed load $l cpu $(cat ${OUT:-/tmp}/t2.txt | tail -1) :: $(grep -o '[0-9.]* mutations/pixel' ${OUT:-/tmp}/l2.txt) $(grep '^b:' ${OUT:-/tmp}/l2.txt) :: $(grep -i 'relmse' ${OUT:-/tmp}/l2.txt | head -2 | tr '\n' ' ')"
done; done; done
