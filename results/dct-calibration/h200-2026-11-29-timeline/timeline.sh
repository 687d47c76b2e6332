#!/usr/bin/env bash
# Device call: timelines of DCT cuda frames (dtflop run --timeline), pinned and pageable, small to
# large; the CUPTI tests of the code that keeps the records.
set -uo pipefail
tar -xJf .carry-gpu.tar.xz
export LD_LIBRARY_PATH=$PWD/.carry-gpu/lib
B=.carry-gpu/bin
S=$OUT/timeline; mkdir -p $S/tests
nvidia-smi -L > $S/gpu.txt
timeout 120 $B/test_calibrate_gpu > $S/tests/test_calibrate_gpu.log 2>&1; echo "test_calibrate_gpu rc=$?"; tail -n 1 $S/tests/test_calibrate_gpu.log
i=0
while read -r size dots radius points support interp mem seed; do
  i=$((i+1))
  n=$(printf "%02d-%s-%s-%s" $i $size $interp $mem)
  timeout 120 $B/dtflop run dct --backend cuda --size $size --dots $dots --radius $radius --points $points \
    --support $support --interp $interp --host-memory $mem --specimen-seed $seed --steps 10 --reps 5 \
    --timeline $S/$n.trace.json --json -o $S/$n.run.json > $S/$n.txt 2> $S/$n.err
  echo "$n rc=$?"; tail -n 1 $S/$n.err
done <<'LIST'
736x720 1193 4.5 36x35 11 mls pinned 624494
1232x824 1530 5.5 27x17 90 fe pinned 1
1346x782 882 7.0 53x31 38 fe pinned 1
1668x1080 322 16.0 57x36 24 mls pinned 1
4156x2682 184 11.5 53x35 98 mls pinned 1
736x720 1193 4.5 36x35 11 mls pageable 624494
1526x1244 189 11.5 30x30 40 mls pageable 1
3114x2408 1099 18.0 40x30 60 mls pageable 1
LIST
cd $OUT && tar -cJf timeline.tar.xz timeline && rm -rf timeline
