#!/usr/bin/env bash
# does the DCT cuda host work's speed follow the CPU the process runs on?
set -uo pipefail
tar -xJf .carry-gpu.tar.xz
export LD_LIBRARY_PATH=$PWD/.carry-gpu/lib
D=.carry-gpu/bin/dtflop
S=$OUT/place; mkdir -p $S
lscpu > $S/lscpu.txt; cat /sys/devices/system/cpu/cpu*/topology/thread_siblings_list 2>/dev/null | paste -sd' ' > $S/siblings.txt
cfg="--size 660x544 --dots 1019 --radius 4 --points 33x28 --support 30"
one() { $D run dct --backend cuda $cfg --steps 20 --json 2>/dev/null | jq -r '[.measured_per_step.C.median, .measured_per_step.total.median] | @tsv'; }
echo "pass cpu C_s total_s" > $S/place.tsv
end=$(( $(date +%s) + 200 ))
for pass in 1 2; do
  for c in $(seq 0 15); do
    [ $(date +%s) -lt $end ] || break
    echo "$pass $c $(taskset -c $c bash -c "$(declare -f one); D=$D cfg='$cfg'; one")" >> $S/place.tsv
  done
  for k in 1 2 3 4; do echo "$pass any $(one)" >> $S/place.tsv; done
done
cat $S/place.tsv; cat $S/siblings.txt
cd $OUT && tar -cf place.tar place && rm -rf place
