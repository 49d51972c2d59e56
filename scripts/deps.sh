#!/usr/bin/env bash
# Installs the Debian packages gyro_allan needs to build, test and plot (ROS 1 from Debian's own archive).
set -euo pipefail
PKGS=(
  cmake g++ make pkg-config
  catkin libroscpp-dev librosbag-dev rosbash pluginlib-dev
  libnodeletlib-dev libnodeletlib-tools
  libsensor-msgs-dev libgeometry-msgs-dev libdiagnostic-msgs-dev libdiagnostic-updater-dev
  ros-message-generation ros-message-runtime ros-std-msgs ros-sensor-msgs ros-geometry-msgs
  librostest-dev python3-rostest python3-roslaunch python3-rosmaster python3-rosbag rosout
  python3-diagnostic-msgs
  libdynamic-reconfigure-config-init-mutex-dev python3-dynamic-reconfigure ros-std-srvs libstd-srvs-dev
  python3-rostopic python3-rosservice python3-std-srvs
  libgtest-dev libbenchmark-dev libeigen3-dev libyaml-cpp-dev libboost-dev zlib1g-dev
  libsqlite3-dev libzstd-dev liblz4-dev
  python3-numpy python3-matplotlib python3-yaml
  libopencv-imgproc-dev
)
missing=()
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "deps: installing ${missing[*]}" >&2
  SUDO=""
  [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi
