#!/usr/bin/env bash
# Newcomer's main job: install what is missing, build, and analyse the bundled bag bags/default.bag.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/deps.sh
bash scripts/build.sh >/dev/null
export PATH=/usr/bin:/bin:$PATH
set +u
source .build/devel/setup.bash
set -u
rosrun gyro_allan analyze_bag bags/default.bag --output "${1:-out/default}"
