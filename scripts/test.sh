#!/usr/bin/env bash
# The test suite as two pytest processes side by side, one per core of a 2-core machine:
# the ROS tests in one, in file order (some rely on it: the last test of
# tests/test_ros_suite.py kills its suite's simulation node), with the longest core
# modules (marker `second_half`, tests/conftest.py), everything else in the other. Arguments go to both pytest runs; TEST_MARK="EXPR" narrows both halves by
# a marker expression (make test: "not slow", the fast tier). Exit status: 0 when both pass.
set -uo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
PY=.venv/bin/python
ros_mark="second_half"
core_mark="not second_half"
if [ -n "${TEST_MARK:-}" ]; then
    ros_mark="second_half and ($TEST_MARK)"
    core_mark="not second_half and ($TEST_MARK)"
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
"$PY" -m pytest -q -p no:cacheprovider -m "$ros_mark" --basetemp "$tmp/ros" "$@" tests \
    > "$tmp/ros.log" 2>&1 &
ros_pid=$!
"$PY" -m pytest -q -m "$core_mark" --basetemp "$tmp/core" "$@" tests
core=$?
wait "$ros_pid"
ros=$?
echo "--- the second half: the ROS tests and the modules beside them (tests/conftest.py) ---"
cat "$tmp/ros.log"
# 5: no test selected (e.g. -k matching none of one half)
[ "$core" -eq 0 ] || [ "$core" -eq 5 ] || exit "$core"
[ "$ros" -eq 0 ] || [ "$ros" -eq 5 ] || exit "$ros"
exit 0
