#!/usr/bin/env bash
# Benchmarks the tracking node (issue 6's bars) on a simulated single-plane knee trial:
#   1. ~play_bag on a 200-frame trial from a crude first-frame guess (femur 3 mm in-plane and
#      20 mm along the beam off, tibia 3 mm and 45 mm off and turned 10 deg about its long
#      axis), and from no guess at all, with ~recover: frames within the 1 mm / 2 / 3 deg
#      criteria, and frames per second from the service's own timing;
#   2. live latency: latency_benchmark publishes the trial at 30 Hz into the node and prints
#      the publish-to-tf latency and the frames the node dropped, with the node's default
#      queue (~queue_size 30) and with the latest frame only (~queue_size 1).
# Usage: scripts/node_benchmark.sh [frames (200)]   (after scripts/build.sh)
set -euo pipefail
cd "$(dirname "$0")/.."
export PATH="/usr/bin:$PATH"
frames="${1:-200}"
set +u
# shellcheck disable=SC1091
source build/devel/setup.bash
set -u
bin=build/devel/lib/fluoro_tracker
work=$(mktemp -d /tmp/node_benchmark.XXXXXX)
cleanup() {
  rosnode kill -a > /dev/null 2>&1 || true
  [ -n "${master_pid:-}" ] && kill "$master_pid" 2> /dev/null || true
  wait 2> /dev/null || true
}
trap cleanup EXIT

"$bin/simulate_trial" --frames "$frames" -o "$work/trial" > /dev/null
/usr/bin/python3 - "$work/trial" <<'PY'
import math, re, sys
folder = sys.argv[1]
text = open(folder + "/trial.yaml").read()
# No guess: drop every initial_pose block (its line and the two below it).
lines = text.split("\n")
kept, skip = [], 0
for line in lines:
    if "initial_pose:" in line:
        skip = 2
        continue
    if skip:
        skip -= 1
        continue
    kept.append(line)
open(folder + "/no_guess.yaml", "w").write("\n".join(kept))
# Crude guess: offsets in the optical frame (the trial's fixed frame): x, y in-plane, z along
# the beam; the tibia also turned 10 deg about its own long axis (Y).
offsets = [(0.003, -0.003, 0.020, 0.0), (-0.003, 0.003, -0.045, 10.0)]
poses = re.findall(r"position_m: \[([^\]]*)\]\n(\s*)orientation_xyzw: \[([^\]]*)\]", text)
out = text
for (position, indent, orientation), (dx, dy, dz, turn_deg) in zip(poses, offsets):
    p = [float(v) for v in position.split(",")]
    x, y, z, w = [float(v) for v in orientation.split(",")]
    h = math.radians(turn_deg) / 2.0  # q * (0, sin h, 0, cos h): a turn about the bone's Y
    s, c = math.sin(h), math.cos(h)
    q = (x * c - z * s, y * c + w * s, z * c + x * s, w * c - y * s)
    new_position = "%.9f, %.9f, %.9f" % (p[0] + dx, p[1] + dy, p[2] + dz)
    new_orientation = ", ".join("%.12f" % v for v in q)
    out = out.replace("position_m: [%s]\n%sorientation_xyzw: [%s]" % (position, indent, orientation),
                      "position_m: [%s]\n%sorientation_xyzw: [%s]" % (new_position, indent,
                                                                     new_orientation))
open(folder + "/crude_guess.yaml", "w").write(out)
PY

roscore > "$work/roscore.log" 2>&1 &
master_pid=$!
sleep 3
for guess in crude_guess no_guess; do
  "$bin/tracker_node" __name:=tracker_node _config:="$work/trial/$guess.yaml" _recover:=true \
    > "$work/node_$guess.log" 2>&1 &
  for _ in $(seq 1 60); do
    rosservice list 2> /dev/null | grep -q /tracker_node/play_bag && break
    sleep 0.5
  done
  reply=$(rosservice call /tracker_node/play_bag "{bag_path: $work/trial/trial.bag,
    image_topics: [], output_bag_path: '', poses_csv_path: $work/$guess.csv,
    kinematics_csv_path: ''}")
  seconds=$(echo "$reply" | awk '/^seconds:/ {print $2}')
  tracked=$(echo "$reply" | awk '/^frames_tracked:/ {print $2}')
  label=${guess/crude_guess/a crude guess}; label=${label/no_guess/no guess}
  echo "node_benchmark: play_bag from $label: $tracked of $frames frames tracked in" \
    "$seconds s ($(/usr/bin/python3 -c "print('%.1f' % ($frames / $seconds))") frames/s);" \
    "$("$bin/score_poses" --poses "$work/$guess.csv" --truth "$work/trial/ground_truth.csv" |
      sed 's/^score_poses: //; s/; RMS.*//')"
  rosnode kill /tracker_node > /dev/null 2>&1
  sleep 1
done
kill "$master_pid"
wait "$master_pid" 2> /dev/null || true
master_pid=
# Live at 30 Hz: with the node's default queue (every frame tracked, a backlog after slow
# frames), then keeping only the latest frame (lowest latency, frames dropped when busy).
for queue_size in 30 1; do
  roslaunch fluoro_tracker latency_benchmark.launch trial:="$work/trial" queue_size:="$queue_size" 2>&1 |
    grep "latency_benchmark:" | sed "s/^/node_benchmark: queue_size $queue_size: /"
done
rm -rf "$work"
