#!/bin/sh
# Equal-time comparison on Tungsten's Cornell box: Tungsten MMLT, our MLT (binaries given), our BDPT;
# interleaved per seed (order rotated), wall time, CPU time and load recorded, and our b line (b from
# the passes, the large steps and both pooled). A BINS path may be a wrapper script adding options.
# TMETHODS: the Tungsten integrators to run (default multiplexed_mlt; e.g. also reversible_jump_mlt).
# On a shared machine run it at high priority: nice -n -15 sh equal_time.sh …
#   BUDGETS="10 30" SEEDS="1 2" BINS="before:PATH after:PATH" BDPT_BIN=PATH sh equal_time.sh TAG
TAG=${1:-cmp}; SCENE=${SCENE:-cornell-box}
S=scenes/$SCENE/scene.xml; O=out/$TAG; mkdir -p $O
T=${TUNGSTEN:-$PWD/build/tungsten}
for B in ${BUDGETS:-10 30}; do
 for tm in ${TMETHODS:-multiplexed_mlt}; do
  python3 tvariant.py scenes/$SCENE/tungsten-base.json $tm $B $O/$tm$B.json --mesh-dir src/data/example-scenes/$(cat scenes/$SCENE/tungsten-source 2>/dev/null || echo $SCENE) >/dev/null
 done
 for seed in ${SEEDS:-1 2}; do
  run() { # name cmd...
    name=$1; shift; l=$(cut -d' ' -f1 /proc/loadavg)
    /usr/bin/time -f "%e %U %S" -o $O/t.txt "$@" > $O/log.txt 2>&1
    img=$(ls -t $O/${name}_${B}_s$seed.* | head -1)
    echo "$TAG $name $B s$seed load $l wallcpu $(cat $O/t.txt | tail -1) $(grep -o '[0-9.]* mutations/pixel\|[0-9]* spp in\|bootstrap [0-9.]* s' $O/log.txt | tr '\n' ' ') passes $(grep -c ^Completed $O/log.txt) $(grep '^b:' $O/log.txt) :: $(python3 score.py $SCENE $img | cut -c60-)"
  }
  for tm in ${TMETHODS:-multiplexed_mlt}; do
    run t$tm sh -c "cd $O && $T -t 2 -s $seed -e $PWD/$O/t${tm}_${B}_s$seed.pfm $tm$B.json"
  done
  for nb in ${BINS}; do n=${nb%%:*}; b=${nb#*:}
    run mlt-$n $b render $S --method mlt --threads 2 --seed $seed --time $B -o $O/mlt-${n}_${B}_s$seed.exr --quiet
  done
  run bdpt ${BDPT_BIN:?set BDPT_BIN to a cmlt binary} render $S --method bdpt --threads 2 --seed $seed --time $B -o $O/bdpt_${B}_s$seed.exr --quiet
 done
done
