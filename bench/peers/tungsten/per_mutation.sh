#!/bin/sh
# Our MLT at MPP mutations per pixel (64), 2 seeds, settings from stdin ("name --opt value" per line):
# relMSE per mutation and CPU seconds. Run from the peer folder: B=cmlt sh per_mutation.sh < list
mkdir -p out/exp
B=${B:?set B to a cmlt binary}; S=scenes/cornell-box/scene.xml; MPP=${MPP:-64}; TAG=${TAG:-e2}
while read name args; do
  for seed in 1 2; do
    out=out/exp/${TAG}_${name}_s$seed.exr
    l=$(cut -d' ' -f1 /proc/loadavg)
    /usr/bin/time -f "%e %U %S" -o out/exp/time.txt $B render $S --method mlt --threads 2 --seed $seed --mutations-per-pixel $MPP $args -o $out --quiet > out/exp/line.txt 2>/dev/null
    line=$(grep mutations/pixel out/exp/line.txt | sed 's/: \([0-9.]*\) M mutations.*accepted/ acc/; s/; mean rgb.*//')
    echo "$name s$seed load $l cpu $(cat out/exp/time.txt) :: $line :: $(python3 score.py cornell-box $out | cut -c60-)"
  done
done
