#!/usr/bin/env bash
# Full soak of the analyzer nodelet: test/nodelet_soak.test at 10 kHz for 10 min (default) with a steady sprinkling
# of bad messages; prints messages sent/accepted/rejected and the nodelet's RSS at start and end.
# Usage: scripts/soak.sh [SECONDS=600] [RATE_HZ=10000]   (BUILD_DIR defaults to .build, built with --tests)
set -euo pipefail
cd "$(dirname "$0")/.."
export PATH=/usr/bin:/bin:$PATH
SECS=${1:-600}
RATE=${2:-10000}
BUILD_DIR=${BUILD_DIR:-.build}
if [ ! -x "$BUILD_DIR/devel/lib/gyro_allan/nodelet_soak" ]; then
  bash scripts/deps.sh
  BUILD_DIR=$BUILD_DIR bash scripts/build.sh >/dev/null
  cmake --build "$BUILD_DIR" --target nodelet_soak -j"${JOBS:-2}"
fi
export ROS_HOSTNAME=localhost
ROS_HOME=$(mktemp -d)
export ROS_HOME ROS_LOG_DIR="$ROS_HOME/log"
set +u
source "$BUILD_DIR/devel/setup.bash"
set -u
log="$ROS_HOME/soak.out"
rc=0
rostest --text gyro_allan nodelet_soak.test duration_s:="$SECS" rate_hz:="$RATE" time_limit:="$((SECS + 180))" \
  >"$log" 2>&1 || rc=$?
cat "$BUILD_DIR/test_out/nodelet_soak.txt" 2>/dev/null || true
grep -E "\[ *(OK|FAILED) *\]|Failure|Expected|Which is" "$log" || tail -40 "$log"
echo "soak: rostest exit $rc (full log $log)"
exit $rc
