#!/usr/bin/env bash
# Installs dependencies, builds, and runs the demo: simulates a single-plane total-knee trial
# (femoral and tibial components moving through a flexion cycle, femur resting on the insert)
# and shows where the bag, ground truth and preview went.
set -euo pipefail
cd "$(dirname "$0")/.."
export PATH="/usr/bin:$PATH"
bash scripts/install_dependencies.sh
bash scripts/build.sh
# ROS's setup scripts read unset variables.
set +u
# shellcheck disable=SC1091
source build/devel/setup.bash
set -u
out="${DEMO_OUTPUT:-demo_output}"
build/devel/lib/fluoro_tracker/simulate_trial --config config/simulate_knee.yaml --output "$out"
echo
echo "demo: open $out/preview.png (first frame, deepest flexion, last frame)."
echo "demo: inspect the bag with 'rosbag info $out/trial.bag', or replay it on a master with"
echo "      'roslaunch fluoro_tracker play_trial.launch bag:=\$PWD/$out/trial.bag'."
