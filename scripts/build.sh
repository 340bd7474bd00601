#!/usr/bin/env bash
# Configures and builds fluoro_tracker standalone (catkin, Release) into ./build.
set -euo pipefail
cd "$(dirname "$0")/.."
# catkin's helpers need Debian's python3, not a pyenv shim that may come first in PATH.
export PATH="/usr/bin:$PATH"
build_type="${BUILD_TYPE:-Release}"
cmake -S . -B build -DCMAKE_BUILD_TYPE="$build_type" -DPYTHON_EXECUTABLE=/usr/bin/python3 > build.log 2>&1 \
  || { cat build.log; echo "build: cmake configuration failed (log above)"; exit 1; }
cmake --build build -j"$(nproc)" >> build.log 2>&1 \
  || { tail -50 build.log; echo "build: compilation failed (last lines above, all in build.log)"; exit 1; }
echo "build: ok ($build_type) — tools in build/devel/lib/fluoro_tracker, log in build.log"
