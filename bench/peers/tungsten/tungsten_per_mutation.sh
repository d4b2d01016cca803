#!/bin/sh
# Tungsten MMLT at a fixed number of passes (mutations per pixel), 2 seeds: relMSE per mutation.
O=out/tspp; mkdir -p $O; SPP=${SPP:-64}
python3 tvariant.py scenes/cornell-box/tungsten-base.json multiplexed_mlt 0 $O/mmlt.json --spp $SPP --mesh-dir src/data/example-scenes/cornell-box > /dev/null
for seed in 1 2; do
  (cd $O && /usr/bin/time -f "%e %U %S" -o t.txt ${TUNGSTEN:-$PWD/../../build/tungsten} -t 2 -s $seed -e $PWD/mmlt_s$seed.pfm mmlt.json > log_s$seed.txt 2>&1)
  echo "tmmlt spp $SPP s$seed wallcpu $(cat $O/t.txt) passes $(grep -c ^Completed $O/log_s$seed.txt) :: $(python3 score.py cornell-box $O/mmlt_s$seed.pfm | cut -c60-)"
done
