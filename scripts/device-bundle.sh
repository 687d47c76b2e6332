#!/usr/bin/env bash
# Builds executables for another machine (typically a GPU machine with the same OS and driver
# but no build toolchain) and gathers them, with the non-system shared libraries they need,
# into one folder: bin/ and lib/.
#
#   scripts/device-bundle.sh [-o FOLDER] [-b BUILD] [-m MIB] TARGET...
#     -o FOLDER  where the bundle goes (default .carry/; it is emptied first)
#     -b BUILD   build folder (default build-device/), configured Release with
#                DTFLOP_IMAGE_IO=OFF: OpenCV's image codecs and video I/O alone pull in ~180 MiB
#                of libraries, so the commands that read or write image files are left out;
#                and DTFLOP_WITH_MPI=OFF: the GPU machine has no OpenMPI (dtflop sar says so)
#     -m MIB     fail when the bundle is larger (default 60)
#   JOBS=n sets the build's parallel jobs (default: all cores).
#   e.g. scripts/device-bundle.sh dtflop test_rbe_gpu bench_rbe
#        scripts/device-bundle.sh -o .carry-calib dtflop test_calibrate_gpu test_rbe_gpu test_probes_gpu
#
# On the other machine, from a copy of the repository with the bundle at the same place:
#   export LD_LIBRARY_PATH=$PWD/.carry/lib; .carry/bin/dtflop probe
# NCCL (cuda-bands between GPUs, the probe gpu-peer) is never bundled: libnccl.so.2 is ~218 MB,
# far over what a bundle may hold. The executables need it by its soname, libnccl.so.2, so any
# NCCL 2 on the other machine serves; where the toolkit there has none, point the loader at
# PyTorch's bundled one too:
#   export LD_LIBRARY_PATH=$PWD/.carry/lib:$(python3 -c 'import nvidia.nccl, os; print(os.path.join(nvidia.nccl.__path__[0], "lib"))')
# The device scripts (benchmarks/rbe/device*.sh, benchmarks/calibrate/gpu.sh) take the bundle
# folder as BUNDLE=FOLDER (default .carry).
set -euo pipefail
cd "$(dirname "$0")/.."
out=.carry
build=build-device
max_mib=60
usage() { echo "usage: $0 [-o FOLDER] [-b BUILD] [-m MIB] TARGET...   (e.g. $0 dtflop test_rbe_gpu)" >&2; exit 2; }
while getopts "o:b:m:h" opt; do
  case $opt in
    o) out=${OPTARG%/} ;;
    b) build=${OPTARG%/} ;;
    m) max_mib=$OPTARG ;;
    *) usage ;;
  esac
done
shift $((OPTIND - 1))
(($#)) && [ -n "$out" ] && [ -n "$build" ] || usage
# The folder is emptied first: refuse one that holds anything but an earlier bundle.
if [ -e "$out" ] && { [ "$out" = "$build" ] || [ -n "$(ls -A "$out" | grep -vx 'bin\|lib')" ] ||
                      [ -n "$(git ls-files -- "$out" 2>/dev/null | head -n 1)" ]; }; then
  echo "device-bundle: $out/ holds more than an earlier bundle (bin/, lib/); name a folder of its own with -o" >&2
  exit 2
fi

cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DDTFLOP_IMAGE_IO=OFF -DDTFLOP_WITH_MPI=OFF >/dev/null
cmake --build "$build" -j "${JOBS:-$(nproc)}" --target "$@"
rm -rf "$out" && mkdir -p "$out/bin" "$out/lib"
# Libraries every Linux system has, and the driver's own: never bundled. Nor NCCL (see above).
system='^(linux-vdso|libc\.|libm\.|libstdc\+\+|libgcc_s|ld-linux|libpthread|libdl\.|librt\.|libcuda\.|libnccl\.)'
for t in "$@"; do
  exe=$(find "$build" -type f -name "$t" -perm -u+x | head -n 1)
  [ -n "$exe" ] || { echo "device-bundle: no executable named $t in $build/; name a build target" >&2; exit 1; }
  cp "$exe" "$out/bin/"
  # NCCL by its soname only (never a path), so that LD_LIBRARY_PATH on the other machine finds it.
  if readelf -d "$exe" | grep -q 'NEEDED.*nccl' && ! readelf -d "$exe" | grep -q 'NEEDED.*\[libnccl\.so\.2\]'; then
    echo "device-bundle: $t needs NCCL by another name than libnccl.so.2; it would not load on the other machine" >&2
    exit 1
  fi
  ldd "$exe" | awk '$3 ~ /^\// {print $1, $3}' | while read -r name path; do
    [[ "$name" =~ $system ]] && continue
    cp -nL "$path" "$out/lib/"
  done
done
size=$(du -sm "$out" | cut -f1)
echo "device-bundle: $out/ holds $(ls "$out/bin" | wc -l) executables and $(ls "$out/lib" | wc -l) libraries, ${size} MiB" >&2
if git check-ignore -q "$out" 2>/dev/null; then :; else
  echo "device-bundle: $out/ is not git-ignored; add it to .gitignore so that it is never committed" >&2
fi
if ((size > max_mib)); then
  echo "device-bundle: over the limit of $max_mib MiB; bundle fewer targets, or raise -m" >&2
  exit 1
fi
