#!/usr/bin/env bash
# Robustness benchmark: tracking accuracy on simulated total-knee trials (single-plane but for
# one) that each change one thing from the simulator's defaults (config/robustness/*.yaml:
# implant material and polarity, view obliquity, implant size and design, a left knee, fast
# motion, resolution, dose, scatter, blur, an occluding rod, collimation, lab clutter, an image
# intensifier's distortion, a knee travelling across the view, the far leg passing the tracked
# knee, a bi-plane pair whose second beam looks along the thigh). For each
# variant, simulate_trial makes a 60-frame trial (30 for fast_motion) and track_bag tracks it
# with the trial's contact and ligament terms, from frame 0's pose and, with --no-guess, again
# from no pose at all (automatic initialisation and recovery). Prints per variant the frames
# within 1 mm in-plane, 2 deg about X and Z, 3 deg about Y, the frames the status flagged, the
# RMS per degree of freedom and frames per second.
# Usage: scripts/robustness_benchmark.sh [--no-guess] [variant ...]   (after scripts/build.sh)
set -euo pipefail
cd "$(dirname "$0")/.."
export PATH="/usr/bin:$PATH"
no_guess=false
if [ "${1:-}" = "--no-guess" ]; then
  no_guess=true
  shift
fi
variants=("$@")
if [ ${#variants[@]} -eq 0 ]; then
  for f in config/robustness/*.yaml; do variants+=("$(basename "$f" .yaml)"); done
fi
bin=build/devel/lib/fluoro_tracker
work=$(mktemp -d /tmp/robustness_benchmark.XXXXXX)
echo "robustness benchmark: trials and logs in $work"

# "W/M within, F flagged; RMS ...; N frames/s" from a track_bag log.
summarise() {
  local log=$1
  local counts rms rate
  counts=$(grep -o '[0-9]*/[0-9]* frames within' "$log" | sed 's/ frames within/ within/' || true)
  rms=$(grep -o 'RMS tx.*' "$log" | sed 's/ (along the beam)//' || true)
  rate=$(grep -o '[0-9]* tracked, [0-9]* skipped, [0-9]* flagged, [0-9.]* frames/s' "$log" || true)
  echo "${counts:-no accuracy (see $log)}, ${rate:-?}; ${rms}"
}

for variant in "${variants[@]}"; do
  config=config/robustness/$variant.yaml
  [ -f "$config" ] || { echo "robustness benchmark: no variant '$variant' ($config)"; exit 1; }
  out=$work/$variant
  "$bin/simulate_trial" --config "$config" --output "$out" > "$out.simulate.log" 2>&1 \
    || { echo "$variant: simulate_trial failed (see $out.simulate.log)"; continue; }
  "$bin/track_bag" --config "$out/trial.yaml" --bag "$out/trial.bag" \
    --poses-csv "$out/poses.csv" --truth-csv "$out/ground_truth.csv" > "$out.track.log" 2>&1 || true
  echo "$variant, from frame 0's pose: $(summarise "$out.track.log")"
  if $no_guess; then
    grep -v -e "initial_pose:" -e "position_m:" -e "orientation_xyzw:" "$out/trial.yaml" \
      > "$out/trial_no_guess.yaml"
    "$bin/track_bag" --config "$out/trial_no_guess.yaml" --bag "$out/trial.bag" --recover \
      --poses-csv "$out/poses_no_guess.csv" --truth-csv "$out/ground_truth.csv" \
      > "$out.no_guess.log" 2>&1 || true
    echo "$variant, from no guess: $(summarise "$out.no_guess.log")"
  fi
done
