#!/usr/bin/env bash
# Device call: the labelling's whole-frame passes as a term (gpu_frame_pixels at L_GF, probe
# gpu-frame-pass). The GPU probe tests, then the DCT cuda calibration and held-out sets (3 rounds;
# fits and validation on the VM from the stores).
set -uo pipefail
tar -xJf .carry-gpu.tar.xz
export LD_LIBRARY_PATH=$PWD/.carry-gpu/lib
B=.carry-gpu/bin
S=$OUT/fp3; mkdir -p $S/tests
nvidia-smi -L > $S/gpu.txt
timeout 150 $B/test_probes_gpu > $S/tests/test_probes_gpu.log 2>&1; echo "test_probes_gpu rc=$?"; tail -n 1 $S/tests/test_probes_gpu.log
timeout 60 $B/dtflop probe --only gpu-frame-pass --details -o $S/frame-pass-full.json > $S/frame-pass-full.txt 2>&1; echo "frame-pass full rc=$?"; grep -E "L_GF|frame passes" $S/frame-pass-full.txt | head -3
FIT=0 CARRY=.carry-gpu OUT=$S bash benchmarks/dct/device.sh 3 > $S/device.txt 2>&1; echo "device.sh rc=$?"; tail -n 14 $S/device.txt
grep -E "L_GF" $S/dct/probe.txt | head -2
cd $S/dct && xz -9 -T8 *.jsonl; cd $OUT && tar -cf fp3.tar fp3 && rm -rf fp3
