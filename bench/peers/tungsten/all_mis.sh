#!/bin/sh
# Per mutation on every tests/scenes scene: our MLT at MPP mutations/pixel, large steps by MIS off and on, seeds given.
#   CMLT=target/release/cmlt SEEDS="1 2" sh all_mis.sh  (OUT: scratch folder, /tmp)
for S in cornell-box veach-mis veach-bidir veach-ajar caustic-pool glossy-room envmap lights-punctual plastics principled rough-glass surface-detail; do
 R=${SCENES:-$(dirname "$0")/../../../tests/scenes}/$S
 for seed in ${SEEDS:-1}; do for m in false true; do
  /usr/bin/time -f "%U" -o ${OUT:-/tmp}/t3.txt ${CMLT:?set CMLT to a cmlt binary} render $R/scene.xml --method mlt --threads 2 --seed $seed --mutations-per-pixel ${MPP:-32} --large-step-mis $m --reference $R/reference.exr -o ${OUT:-/tmp}/all.exr --quiet > ${OUT:-/tmp}/l3.txt 2>&1
  echo "$S mis=$m s$seed cpu $(cat ${OUT:-/tmp}/t3.txt) $(grep -o 'relMSE [0-9.e-]*' ${OUT:-/tmp}/l3.txt | head -1) $(grep -o 'mean ratio ([0-9., ]*)' ${OUT:-/tmp}/l3.txt)"
 done; done
done
