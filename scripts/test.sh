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
ctest --output-on-failure -j"${JOBS:-2}" --timeout 900
