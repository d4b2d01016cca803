#!/bin/sh
# Our renderer with option sets read from stdin ("name [args…]" per line; "name@BINARY" runs another
# binary), interleaved per seed, at equal wall time (BUDGET seconds) or, with MODE=mpp, at MPP mutations
# per pixel: load, wall and CPU seconds, relMSE against REF (the CLI's --reference), relMSE × CPU s, b
# and the mean ratio. Lines that carry --method override METHOD (mlt), so MLT and BDPT can alternate
# (at equal time; MODE=mpp is for MLT and CMLT lines).
#   B=cmlt SCENE="tests/scenes/S/scene.xml -D resx=128 -D resy=128" REF=tests/scenes/S/reference.exr \
#     BUDGET=10 SEEDS="1 2" TAG=x nice -n -15 sh options.sh < variants       (log: out/TAG.log)
O=${OUT:-out}/${TAG:?}; mkdir -p $O
V=$(cat)
for seed in ${SEEDS:-1 2}; do
  echo "$V" | while read name args; do
    [ -z "$name" ] && continue
    bin=${B:?}
    case $name in *@*) bin=${name#*@}; ;; esac
    l=$(cut -d' ' -f1 /proc/loadavg)
    if [ "${MODE:-time}" = mpp ]; then what="--mutations-per-pixel ${MPP:-64}"; else what="--time ${BUDGET:-10}"; fi
    case "$args" in *--method*) method= ;; *) method="--method ${METHOD:-mlt}" ;; esac
    /usr/bin/time -f "%e %U %S" -o $O/t.txt $bin render ${SCENE:?} $method --threads 2 --seed $seed $what $args --reference ${REF:?} -o $O/${name%%@*}_s$seed.exr --quiet > $O/l.txt 2>&1
    set -- $(tail -1 $O/t.txt); cpu=$(echo "$2 + $3" | bc)
    rel=$(grep -o 'relMSE [0-9.e-]*' $O/l.txt | cut -d' ' -f2)
    echo "$TAG ${name%%@*} s$seed load $l wall $1 cpu $cpu relMSE $rel relxcpu $(echo "$rel * $cpu" | bc -l | cut -c1-8) :: $(grep -o '[0-9.]* mutations/pixel' $O/l.txt) $(grep -o 'b [0-9.]*)' $O/l.txt) $(grep -o 'mean ratio.*' $O/l.txt)"
  done
done | tee -a ${OUT:-out}/$TAG.log
