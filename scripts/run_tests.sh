#!/usr/bin/env bash
# Builds fluoro_tracker and runs every test: gtest units and rostests (which start a real
# master and play a simulated bag). Exits non-zero if anything fails.
set -euo pipefail
cd "$(dirname "$0")/.."
export PATH="/usr/bin:$PATH"
bash scripts/build.sh
# ROS's setup scripts read unset variables.
set +u
# shellcheck disable=SC1091
source build/devel/setup.bash
set -u
rm -rf build/test_results
# Under a virtual X display: the rviz rostest draws config/tracker.rviz and takes a screenshot.
xvfb-run -a -s "-screen 0 1280x800x24" make -C build run_tests > build/run_tests.log 2>&1 ||
  { tail -50 build/run_tests.log; exit 1; }
set +e
summary=$(catkin_test_results --verbose build/test_results)
status=$?
set -e
echo "$summary" | grep -v "^$" | tail -40
# One plain closing line, counted from the individual <testcase> results (catkin's summary
# counts each gtest case once per suite and once per file).
counts=$(/usr/bin/python3 - build/test_results <<'PY'
import pathlib, sys, xml.etree.ElementTree as ET
passed = failed = skipped = 0
for f in pathlib.Path(sys.argv[1]).rglob("*.xml"):
    try:
        root = ET.parse(f).getroot()
    except ET.ParseError:
        # rosunit-* files are written by each test node; hztest nodes leave theirs empty and
        # report through rostest's merged file. Any other unreadable result is a failure.
        if not f.name.startswith("rosunit-"):
            failed += 1
        continue
    for case in root.iter("testcase"):
        if case.find("failure") is not None or case.find("error") is not None:
            failed += 1
        elif case.find("skipped") is not None:
            skipped += 1
        else:
            passed += 1
print(passed, failed, skipped)
PY
)
read -r passed failed skipped <<< "$counts"
if [ "$((passed + failed))" -eq 0 ]; then
  echo "run_tests: no test results were produced"
  exit 1
fi
echo "tests: $passed passed, $failed failed, $skipped skipped"
if [ "$failed" -ne 0 ]; then status=1; fi
exit $status
