#!/bin/sh
# Where the equal-time gap to Tungsten's MMLT comes from, on its Cornell box: per renderer and seed,
# interleaved, (a) a set-up run (1 mutation per pixel: process start, bootstrap and normalisation
# passes, one pass of chains), (b) a timed run (BUDGET s, 2 threads) and (c) a run at MPP mutations per
# pixel. Prints CPU seconds (user + sys) and relMSE of each; with breakdown.py: mutations per CPU second
# of the chains (timed run's CPU less the set-up run's), the set-up share of the timed run, and the error
# per mutation. Our binaries: BINS="name:path …" (a path may be a wrapper adding options).
#   BUDGET=10 MPP=64 SEEDS="1 2" BINS="base:./cmlt-base" sh breakdown.sh TAG | tee out/TAG.log
#   python3 breakdown.py out/TAG.log
TAG=${1:-bd}; O=out/$TAG; mkdir -p $O; B=${BUDGET:-10}; MPP=${MPP:-64}
S=scenes/cornell-box/scene.xml; T=${TUNGSTEN:-$PWD/build/tungsten}
MESH=src/data/example-scenes/cornell-box; P=$((320 * 180))
python3 tvariant.py scenes/cornell-box/tungsten-base.json multiplexed_mlt $B $O/timed.json --mesh-dir $MESH >/dev/null
python3 tvariant.py scenes/cornell-box/tungsten-base.json multiplexed_mlt 0 $O/setup.json --spp 1 --mesh-dir $MESH >/dev/null
python3 tvariant.py scenes/cornell-box/tungsten-base.json multiplexed_mlt 0 $O/mpp.json --spp $MPP --mesh-dir $MESH >/dev/null
cpu() { awk '{ printf "%.2f %.2f", $1, $2 + $3 }' $O/t.txt; }
tung() { # kind seed
  (cd $O && /usr/bin/time -f "%e %U %S" -o t.txt nice -n -15 $T -t 2 -s $2 -e $PWD/t_$1_s$2.pfm $1.json > log.txt 2>&1)
  m=$(( $(grep -c ^Completed $O/log.txt) - 1 ))
  echo "$TAG tmmlt $1 s$2 wall_cpu $(cpu) mutations $((m * P)) relmse $(python3 score.py cornell-box $O/t_$1_s$2.pfm | awk '{print $3}')"
}
ours() { # name bin kind seed
  case $3 in timed) a="--time $B";; setup) a="--mutations-per-pixel 1";; mpp) a="--mutations-per-pixel $MPP";; esac
  /usr/bin/time -f "%e %U %S" -o $O/t.txt nice -n -15 $2 render $S --method mlt --threads 2 --seed $4 $a -o $O/$1_$3_s$4.exr --quiet > $O/log.txt 2>&1
  m=$(grep -o '[0-9.]* mutations/pixel' $O/log.txt | awk -v p=$P '{ printf "%.0f", $1 * p }')
  echo "$TAG $1 $3 s$4 wall_cpu $(cpu) mutations $m relmse $(python3 score.py cornell-box $O/$1_$3_s$4.exr | awk '{print $3}') $(grep -o 'bootstrap [0-9.]* s' $O/log.txt)"
}
echo "$TAG load $(cut -d' ' -f1-3 /proc/loadavg) budget $B mpp $MPP"
for seed in ${SEEDS:-1 2}; do
  for kind in setup timed mpp; do
    tung $kind $seed
    for nb in ${BINS:?set BINS}; do ours ${nb%%:*} ${nb#*:} $kind $seed; done
  done
done
echo "$TAG load $(cut -d' ' -f1-3 /proc/loadavg)"
