#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# ctest's fuzz.<target>: one libFuzzer harness over its committed seed corpus, bounded by time and by runs.
# libFuzzer exits 0 when a bound ends the run, so the test fails only on a finding (a crash, an escaped
# exception, an ASan/UBSan/LeakSanitizer report, one input over 60 s or 2 GiB); the input is then kept as
# <artifacts>/crash-... (or timeout-, oom-, leak-) for `fuzzer <file>` to replay.
# usage: run_fuzzer.sh <fuzzer> <seed corpus> <artifacts dir> <seconds> <runs>
set -euo pipefail
fuzzer=$1 seeds=$2 artifacts=$3 seconds=$4 runs=$5
work=$(mktemp -d /tmp/kiln-fuzz-XXXXXX)
trap 'rm -rf "$work"' EXIT
mkdir -p "$artifacts"
# New inputs go to a scratch directory: the committed corpus is read, never written.
"$fuzzer" -max_total_time="$seconds" -runs="$runs" -timeout=60 -rss_limit_mb=2048 -print_final_stats=1 \
  -artifact_prefix="$artifacts/" "$work" "$seeds"
