#!/usr/bin/env bash
# Installs what dtflop needs from Debian 12 packages (only what is missing) and builds it
# (Release) into build/. Idempotent: run it again and it only rebuilds what changed.
#   scripts/setup.sh [--sanitize] [--fuzz] [--release-tests=all|optimised]
#     --sanitize also builds build-asan/ (ASan + UBSan, host code: the unit tests) and installs
#                what the test suite alone needs
#     --fuzz     also builds the libFuzzer targets of fuzz/ (clang, ASan + UBSan): with
#                --sanitize in build-asan/ itself, one clang build for both (scripts/test.sh passes
#                both), alone in build-fuzz/
#     --release-tests=optimised  build/ builds only the tests that need the optimised build (GPU,
#                install, the main job end to end, the full-set calibration fits, the fuzz corpus
#                replays: DTFLOP_TESTS=optimised, CMakeLists.txt), not the unit tests, which
#                build-asan/ runs: scripts/test.sh on a machine without a GPU. The default, all,
#                builds every test; either is passed each time, so the tree follows the last run.
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(cmake ninja-build g++ pkg-config libeigen3-dev libfmt-dev nlohmann-json3-dev libcli11-dev
          libopencv-dev libceres-dev libgtest-dev libgmock-dev libbenchmark-dev libnanoflann-dev
          libyaml-cpp-dev           # scenario and configuration files (tune/, sar/)
          libopenmpi-dev openmpi-bin  # the search-and-rescue team: one MPI process per helicopter (sar/)
          libaravis-dev libusb-1.0-0-dev  # GenICam cameras (sources/); aravis-0.8.pc needs libusb's .pc
          libcpp-httplib-dev        # the live viewer (sources/viewer.hpp)
          clang libclang-rt-14-dev  # clang + libFuzzer: the fuzz targets (fuzz/)
          xz-utils)                 # the archived stores in results/
# The test suite (--sanitize): headless Chromium and a font, with which the report tests open
# every kind of report as a person would (tests/reports/); the main job does not need them.
for arg in "$@"; do
  # The frame sources' peers (tests/sources/): Aravis's fake GigE Vision camera, GStreamer's
  # videotestsrc and gst-inspect-1.0. LLVM's linker for the sanitized clang tree (below).
  if [ "$arg" = "--sanitize" ]; then
    packages+=(chromium fonts-dejavu-core aravis-tools gstreamer1.0-plugins-base gstreamer1.0-tools lld)
  fi
done
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "setup: installing ${missing[*]}" >&2
  sudo_cmd=()
  [ "$(id -u)" -ne 0 ] && sudo_cmd=(sudo)
  "${sudo_cmd[@]}" apt-get update -qq
  DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" >&2
fi

if [ -x /usr/local/cuda/bin/nvcc ]; then
  echo "setup: CUDA found at /usr/local/cuda: CUDA backends will be built" >&2
else
  echo "setup: no nvcc at /usr/local/cuda: building CPU-only" >&2
fi

sanitize=0
fuzz=0
release_tests=all
for arg in "$@"; do
  case "$arg" in
    --sanitize) sanitize=1 ;;
    --fuzz) fuzz=1 ;;
    --release-tests=all|--release-tests=optimised) release_tests=${arg#--release-tests=} ;;
    *) echo "setup: unknown option '$arg'; use --sanitize, --fuzz, --release-tests=all|optimised" >&2; exit 2 ;;
  esac
done

jobs=$(nproc)
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DDTFLOP_TESTS="$release_tests" >&2
cmake --build build -j "$jobs" >&2

# Host code only in these: the CUDA backends are left out of the sanitized builds, and with them
# the GPU tests; so is the main job end to end, which only the optimised build runs
# (DTFLOP_TESTS=sanitized).
if [ "$sanitize" = 1 ] && [ "$fuzz" = 1 ]; then
  # One clang build for the unit tests and the fuzz targets, at -O2 with line tables: on the
  # 2-core CI machine it builds in 9 minutes and runs the unit tests in 7.5 where gcc's Debug build
  # (12 + 8) and a second, clang build of the fuzz targets (3) took 23 (docs/design.md, "The test
  # suite and CI").
  # A build-asan/ configured with another compiler is started afresh (CMake cannot switch).
  if [ -f build-asan/CMakeCache.txt ] && ! grep -q '^CMAKE_CXX_COMPILER:[A-Z]*=.*clang++$' build-asan/CMakeCache.txt; then
    echo "setup: build-asan/ was configured with another compiler: rebuilding it with clang" >&2
    rm -rf build-asan
  fi
  # Line tables are all a sanitizer's report needs (file and line of each frame), and full debug
  # information made every object half as large again and every link slower.
  # LLVM's linker (lld): its 56 links took 30 CPU-seconds where GNU ld took 89 (the instrumented
  # static libraries are large), about half a minute of the 2-core CI machine's build. And
  # --as-needed: an executable names only the shared libraries it calls into, not all that its
  # static libraries' link interfaces list. Most test executables had OpenCV's image and video I/O
  # and MPI in their list without calling them, about 250 libraries (GDAL, GDCM, FFmpeg, ...) that
  # the loader mapped and resolved in every test's process: 0.45 s of each start under ASan, 0.09
  # with the flag; over the 546 tests' processes 133 CPU-seconds of the unit run, 61 with it.
  cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_COMPILER=clang \
        -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -gline-tables-only -DNDEBUG" \
        -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O2 -gline-tables-only -DNDEBUG" -DDTFLOP_SANITIZE=ON -DDTFLOP_FUZZ=ON \
        -DCMAKE_EXE_LINKER_FLAGS="-fuse-ld=lld -Wl,--as-needed" -DDTFLOP_WITH_CUDA=OFF -DDTFLOP_BUILD_BENCHMARKS=OFF \
        -DDTFLOP_TESTS=sanitized >&2
  cmake --build build-asan -j "$jobs" >&2
elif [ "$sanitize" = 1 ]; then
  cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=Debug -DDTFLOP_SANITIZE=ON \
        -DDTFLOP_WITH_CUDA=OFF -DDTFLOP_BUILD_BENCHMARKS=OFF -DDTFLOP_TESTS=sanitized >&2
  cmake --build build-asan -j "$jobs" >&2
elif [ "$fuzz" = 1 ]; then
  # libFuzzer needs clang; everything is instrumented (fuzzer, ASan, UBSan). Only the fuzz targets
  # and what they link are built.
  cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_COMPILER=clang \
        -DCMAKE_CXX_COMPILER=clang++ -DDTFLOP_FUZZ=ON -DDTFLOP_WITH_CUDA=OFF -DDTFLOP_BUILD_TESTS=OFF \
        -DDTFLOP_BUILD_BENCHMARKS=OFF >&2
  cmake --build build-fuzz -j "$jobs" --target dtflop_fuzz_targets >&2
fi
