#!/usr/bin/env bash
# Builds gyro_allan with plain cmake into .build/ (devel space .build/devel; not build/: rosrun skips it).
# Usage: scripts/build.sh [--tests] [extra cmake -D options]
set -euo pipefail
cd "$(dirname "$0")/.."
export PATH=/usr/bin:/bin:$PATH   # a pyenv python3 earlier on PATH breaks catkin's configure
targets=(all)
if [ "${1:-}" = "--tests" ]; then
  targets=(all tests benchmarks)  # benchmarks are built (not run) so they cannot rot
  shift
fi
BUILD_DIR=${BUILD_DIR:-.build}
mkdir -p "$BUILD_DIR"
cmake -S . -B "$BUILD_DIR" -DCMAKE_BUILD_TYPE=Release -DCATKIN_ENABLE_TESTING=ON "$@" >"$BUILD_DIR/configure.log" 2>&1 \
  || { cat "$BUILD_DIR/configure.log"; exit 1; }
for t in "${targets[@]}"; do
  cmake --build "$BUILD_DIR" --target "$t" -j"${JOBS:-2}"
done
