#!/usr/bin/env bash
# Installs what is missing, builds everything with tests, and runs every test (gtest + rostest) through ctest.
# Exits non-zero on any failure.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/deps.sh
bash scripts/build.sh --tests
export PATH=/usr/bin:/bin:$PATH
export ROS_HOSTNAME=localhost
ROS_HOME=$(mktemp -d)
export ROS_HOME ROS_LOG_DIR="$ROS_HOME/log"
set +u
source .build/devel/setup.bash
set -u
cd .build
# three at a time on two cores: the rostests mostly wait on real-time publishing, a third slot keeps the cores busy
ctest --output-on-failure -j"${TEST_JOBS:-3}" --timeout 900
