#!/bin/sh
# SPDX-License-Identifier: Apache-2.0
# examples.vulkan_triangle.usage: the example records what it selects (KILN_USAGE_LOG), a pack is built from that log
# (kiln build --usage), check-usage finds nothing missing, the narrow pack draws the recorded run's image, and a run
# that asks for something else is refused by the narrow pack (docs/usage.md).
# usage: usage_test.sh KILN PROGRAM PACK_DEFINITION PACK_DIR WORK_DIR
set -eu
kiln=$1 program=$2 definition=$3 pack=$4 work=$5
check="python3 $(dirname "$0")/check_png.py"
rm -rf "$work" && mkdir -p "$work"
KILN_USAGE_LOG="$work/run.json" "$program" "$pack" "$work/recorded.png" INVERT
grep -q '"example": "vulkan_triangle"' "$work/run.json"
"$kiln" build "$definition" -o "$work/narrow" --no-cache --usage "$work/run.json"
"$kiln" check-usage "$work/narrow" "$work/run.json"
"$kiln" inspect "$work/narrow" | grep -q "pass Main: 1 variants" || { "$kiln" inspect "$work/narrow"; echo "FAIL: the narrow pack is not one variant"; exit 1; }
"$program" "$work/narrow" "$work/narrow.png" INVERT
$check "$work/narrow.png" 0 128 255
if "$program" "$work/narrow" "$work/other.png" 2> "$work/other.err"; then
  echo "FAIL: the narrow pack served a variant the recorded run never asked for"; exit 1
fi
grep -q "stripped" "$work/other.err" || { cat "$work/other.err"; echo "FAIL: not refused as stripped"; exit 1; }
echo "usage test passed"
