#!/bin/sh
# SPDX-License-Identifier: Apache-2.0
# examples.vulkan_triangle.*: draws with the example, then checks the image (check_png.py).
# usage: run_and_check.sh PROGRAM PACK_DIR IMAGE "R G B" [KEYWORD]...
set -e
program=$1 pack=$2 image=$3 expected=$4
shift 4
rm -f "$image"
"$program" "$pack" "$image" "$@"
python3 "$(dirname "$0")/check_png.py" "$image" $expected
