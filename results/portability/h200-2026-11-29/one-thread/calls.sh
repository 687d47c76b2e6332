#!/usr/bin/env bash
# Does a one-thread probe read slower inside the full quick probe than alone (package power after all-thread probes)?
set -u
export LD_LIBRARY_PATH=$PWD/.carry-gpu/lib
D=.carry-gpu/bin/dtflop
W=$OUT/turbo; mkdir -p $W
t() { echo "== $* ($(date -u +%T)) MHz: $(grep MHz /proc/cpuinfo | awk '{s+=$4;n++} END {printf "%.0f", s/n}')" >> $W/log.txt; }
lscpu > $W/lscpu.txt; nproc >> $W/lscpu.txt
t start; sleep 20
for i in 1 2; do t win-alone-$i; $D probe --quick --only cpu-window -o $W/win-alone-$i.json > $W/win-alone-$i.txt 2>&1; done
for i in 1 2; do t run-seq-$i; $D run --machine $W/win-alone-1.json rbe --backend cpu-seq --grid 1000x1000 --kernel 33x33 > $W/run-seq-alone-$i.txt 2>&1; done
t full; $D probe --quick -o $W/full.json > $W/full.txt 2>&1
t win-after-full; $D probe --quick --only cpu-window -o $W/win-after-full.json > $W/win-after-full.txt 2>&1
t sleep30; sleep 30
t win-after-sleep; $D probe --quick --only cpu-window -o $W/win-after-sleep.json > $W/win-after-sleep.txt 2>&1
t fma-win; $D probe --quick --only cpu-fma,cpu-window -o $W/fma-win.json > $W/fma-win.txt 2>&1
sleep 20
t mem-win; $D probe --quick --only cpu-memory,cpu-window -o $W/mem-win.json > $W/mem-win.txt 2>&1
sleep 20
for i in 1 2; do t run-seq-full-$i; $D run --machine $W/full.json rbe --backend cpu-seq --grid 1000x1000 --kernel 33x33 > $W/run-seq-full-$i.txt 2>&1; done
t run-dct; $D run --machine $W/full.json dct --backend cpu-seq > $W/run-dct-seq.txt 2>&1
t win-end; $D probe --quick --only cpu-window -o $W/win-end.json > $W/win-end.txt 2>&1
t done
tar -czf $OUT/turbo.tgz -C $OUT turbo && rm -rf $W
