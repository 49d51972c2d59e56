#!/usr/bin/env bash
# Builds the libFuzzer targets in fuzz/ with clang (ASan + UBSan) outside catkin and runs each for a bounded time.
# Usage: scripts/fuzz.sh [SECONDS_PER_TARGET=60] [TARGET...]   (targets: csv analysis wavelet ros2; default all)
# New crashers are written to fuzz/crashers/<target>/; copy the ones you fixed to fuzz/regressions/<target>/
# (test/test_robustness.cpp replays them). Exits non-zero if a target crashed.
set -euo pipefail
cd "$(dirname "$0")/.."
SECS=${1:-60}
shift || true
TARGETS=("$@")
[ ${#TARGETS[@]} -eq 0 ] && TARGETS=(csv analysis wavelet ros2)

# Own dependency step (not scripts/deps.sh: the normal build does not need clang).
need=()
for p in clang libclang-rt-14-dev libeigen3-dev libyaml-cpp-dev libsqlite3-dev libzstd-dev liblz4-dev zlib1g-dev; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "ok installed" || need+=("$p")
done
if [ ${#need[@]} -gt 0 ]; then
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${need[@]}" >/dev/null
fi

OUT=${FUZZ_BUILD_DIR:-.build-fuzz}
mkdir -p "$OUT/obj"
CXX=${CXX_FUZZ:-clang++}
FLAGS=(-std=c++17 -O1 -g -fno-omit-frame-pointer -fsanitize=address,undefined -fno-sanitize-recover=undefined
       -I include -I /usr/include/eigen3 -DEIGEN_NO_DEBUG)
# Core library objects (instrumented for coverage, no main), rebuilt only when the source is newer.
objs=()
for src in src/core/*.cpp src/rosbag2/*.cpp; do
  o="$OUT/obj/$(basename "${src%.cpp}").o"
  if [ ! -f "$o" ] || [ "$src" -nt "$o" ] || [ -n "$(find include -newer "$o" -name '*.hpp' | head -1)" ]; then
    echo "fuzz: compiling $src" >&2
    $CXX "${FLAGS[@]}" -fsanitize=fuzzer-no-link -c "$src" -o "$o"
  fi
  objs+=("$o")
done
export ASAN_OPTIONS=${ASAN_OPTIONS:-halt_on_error=1:detect_leaks=1:allocator_may_return_null=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1}
status=0
for t in "${TARGETS[@]}"; do
  bin="$OUT/fuzz_$t"
  $CXX "${FLAGS[@]}" -fsanitize=fuzzer "fuzz/fuzz_$t.cpp" "${objs[@]}" -lyaml-cpp -lsqlite3 -lzstd -llz4 -lz -lpthread \
      -o "$bin"
  work="$OUT/corpus_$t"  # grows here; fuzz/corpus/<target>/ is the small seed corpus kept in git
  mkdir -p "$work" "fuzz/crashers/$t" "fuzz/regressions/$t"  # libFuzzer stops on a missing corpus folder
  echo "fuzz: running $t for ${SECS}s" >&2
  maxlen=4096
  [ "$t" = ros2 ] && maxlen=65536  # storage files: a .db3 is several 4 KiB pages
  if ! "$bin" "$work" "fuzz/corpus/$t" "fuzz/regressions/$t" -max_total_time="$SECS" -max_len="$maxlen" -timeout=10 \
       -rss_limit_mb=2048 -artifact_prefix="fuzz/crashers/$t/" -print_final_stats=1 >"$OUT/fuzz_$t.log" 2>&1; then
    echo "fuzz: $t FAILED (see $OUT/fuzz_$t.log and fuzz/crashers/$t/)" >&2
    tail -40 "$OUT/fuzz_$t.log" >&2
    status=1
  else
    grep -E "^stat::number_of_executed_units|^#[0-9]+ *DONE" "$OUT/fuzz_$t.log" | tail -2 >&2 || true
  fi
done
exit $status
