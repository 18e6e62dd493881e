#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Opening a pack, selecting and first use, as a game does (bench/pack_open.cpp through the C API), on the default
# pack (variants/lit.pack.json) and on a 10x synthetic one (bench/synthetic_pack.cpp), with the RSS of each step.
# With OLD_SOURCE (a checkout of an older kiln) and OLD_PACK (the default pack as that kiln built it), the same
# benchmark source is built against each reader's sources with the same flags (g++ -O2) and the two are run
# interleaved, for a side-by-side comparison on one machine.
#
#   bench/pack_open.sh BUILD_DIR [OLD_SOURCE OLD_PACK]     (writes bench/results/pack_open-<date>.txt)
set -euo pipefail
source_dir=$(cd "$(dirname "$0")/.." && pwd)
build=$(cd "$1" && pwd)
old_source=${2:-} old_pack=${3:-}
work=$(mktemp -d /tmp/kiln-pack-open-XXXXXX)
trap 'rm -rf "$work"' EXIT
out="$source_dir/bench/results/pack_open-$(date +%Y-%m-%d).txt"
exec > >(tee "$out") 2>&1

echo "# $(date -u +%FT%TZ) $(uname -n), $(nproc) cores; kiln $(git -C "$source_dir" rev-parse --short HEAD)"
"$build/compiler/kiln" build "$source_dir/variants/lit.pack.json" -o "$work/lit" --cache "$work/cache" -q
"$build/bench/kiln-synthetic-pack" "$work/lit" 10 "$work/litx10" > /dev/null
ls -l "$work"/lit/*.kpack "$work"/lit/*.json "$work"/litx10/*.kpack "$work"/litx10/*.json | awk '{print $5, $9}'
# One harness, built against a reader's sources: the same compiler and flags for both.
reader() {  # reader NAME SOURCE_DIR
  local objects=()
  for file in "$2"/compiler/src/reader/*.cpp; do
    c++ -std=c++20 -O2 -DNDEBUG -I"$2/compiler/include" -c "$file" -o "$work/$1-$(basename "$file" .cpp).o"
    objects+=("$work/$1-$(basename "$file" .cpp).o")
  done
  c++ -std=c++20 -O2 -DNDEBUG -I"$2/compiler/include" "$source_dir/bench/pack_open.cpp" "${objects[@]}" \
    -lbenchmark -lpthread -lxxhash -lzstd -o "$work/$1-pack-open"
}
reader new "$source_dir"
runs=(new)
if [ -n "$old_source" ]; then
  reader old "$old_source"
  cp -r "$old_pack" "$work/old-lit"
  runs+=(old)
fi
for round in 1 2 3; do
  for run in "${runs[@]}"; do
    if [ "$run" = new ]; then
      echo "## round $round: this reader"
      "$work/new-pack-open" "$work/lit" "$work/litx10" --benchmark_repetitions=5 --benchmark_report_aggregates_only=true \
        --benchmark_min_time=0.2
    else
      echo "## round $round: the older reader ($(git -C "$old_source" rev-parse --short HEAD))"
      "$work/old-pack-open" "$work/old-lit" --benchmark_repetitions=5 --benchmark_report_aggregates_only=true \
        --benchmark_min_time=0.2
    fi
  done
done
for pack in lit litx10; do
  echo "## RSS, this reader, $pack"
  "$work/new-pack-open" --rss "$work/$pack"
done
if [ -n "$old_source" ]; then
  echo "## RSS, the older reader, lit"
  "$work/old-pack-open" --rss "$work/old-lit"
fi
