#!/usr/bin/env bash
# Installs fluoro_tracker's build and test dependencies from Debian's packages (bookworm's ROS1
# Noetic-era packages). Needs root or sudo.
set -euo pipefail

packages=(
  build-essential cmake pkg-config clang-format
  catkin python3-catkin-pkg ros-core-dev rosbash ros-message-generation ros-message-runtime
  libroscpp-dev librosbag-dev python3-rosbag python3-rostest libgtest-dev
  libstd-msgs-dev libgeometry-msgs-dev libsensor-msgs-dev libvisualization-msgs-dev
  libtf2-ros-dev libtf2-eigen-dev libcv-bridge-dev libimage-transport-dev
  libmessage-filters-dev libnodeletlib-dev libnodeletlib-tools pluginlib-dev
  libdiagnostic-updater-dev
  libeigen3-dev libopencv-dev libfcl-dev libceres-dev libassimp-dev libyaml-cpp-dev
  libboost-program-options-dev
  rviz xvfb xauth scrot
  python3-rosservice python3-std-msgs python3-geometry-msgs
)

sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then sudo_cmd=(sudo); fi

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install_dependencies: all ${#packages[@]} packages already installed"
  exit 0
fi
echo "install_dependencies: installing ${#missing[@]} package(s): ${missing[*]}"
"${sudo_cmd[@]}" apt-get update -qq
DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
