#!/bin/sh
# CPU seconds of our MLT on Tungsten's Cornell box at MPP mutations per pixel (64), 2 threads, for
# several binaries interleaved over REPS seeds (3), with relMSE and the largest pixel difference from the
# first binary's image of the same seed (0: identical images). Run at high priority on a shared machine.
#   BINS="before:PATH after:PATH" MPP=64 REPS=3 nice -n -15 sh cpu_ab.sh TAG [more cmlt options]
TAG=${1:?TAG}; shift; O=out/$TAG; mkdir -p $O
echo "$TAG load $(cut -d' ' -f1-3 /proc/loadavg)"
for r in $(seq 1 ${REPS:-3}); do first=; for nb in ${BINS:?set BINS}; do n=${nb%%:*}; b=${nb#*:}
  img=$O/${n}_s$r.exr; first=${first:-$img}
  /usr/bin/time -f "%e %U %S" -o $O/t.txt $b render scenes/cornell-box/scene.xml --method mlt --threads 2 --seed $r --mutations-per-pixel ${MPP:-64} "$@" -o $img --quiet > $O/l.txt 2>&1
  diff=$(python3 -c "import imgtools as it; print(abs(it.read_image('$img') - it.read_image('$first')).max())")
  echo "$TAG $n s$r cpu $(awk '{print $2+$3}' $O/t.txt) relmse $(python3 score.py cornell-box $img | awk '{print $3}') maxdiff $diff"
done; done
echo "$TAG load $(cut -d' ' -f1-3 /proc/loadavg)"
