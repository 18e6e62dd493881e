#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Reruns the instruments behind bench/REPORT.md from scratch: installs the Debian packages, builds, runs the
# instruments into bench/results/, then bench/report.py, which writes their tables to bench/results/REPORT.generated.md
# and the plots to bench/plots/ (bench/REPORT.md's sections take their current figures from there). About 95
# minutes on 2 cores; do not run other heavy jobs meanwhile (the build benchmark edits shaderlib/Fog.hlsl
# temporarily and restores it).
set -euo pipefail
cd "$(dirname "$0")/.."
bash .ci/install-deps
cmake --preset ci
cmake --build --preset ci
mkdir -p bench/results
# The same kiln on glibc's malloc, for the allocator comparison (bench/REPORT.md, "The cold build").
cmake -S . -B build/glibc -G Ninja -DCMAKE_BUILD_TYPE=Release -DKILN_MIMALLOC=OFF -DKILN_BUILD_TESTS=OFF -DKILN_BUILD_BENCH=OFF
cmake --build build/glibc --target kiln kiln-worker
python3 bench/build_speed.py --kiln build/ci/compiler/kiln --kiln-glibc build/glibc/compiler/kiln \
  --floor-tool build/ci/bench/kiln-compile-steps --reps 3
# Where one compile's time goes: the largest Forward fragment and vertex sources of the default pack.
steps_dir=$(mktemp -d)
build/ci/compiler/kiln build variants/lit.pack.json -o "$steps_dir" --cache build/ci/kiln-cache --emit preprocessed -q
build/ci/bench/kiln-compile-steps "$(ls -S "$steps_dir"/emit/Forward/fragment/*.hlsl | head -1)" fragment LitFragment 15 \
  --json bench/results/compile_steps_fragment.json
build/ci/bench/kiln-compile-steps "$(ls -S "$steps_dir"/emit/Forward/vertex/*.hlsl | head -1)" vertex LitVertex 15 \
  --json bench/results/compile_steps_vertex.json
rm -rf "$steps_dir"
python3 bench/scaling.py --kiln build/ci/compiler/kiln
KILN_STRESS_REPORT="$PWD/bench/results/stress.json" KILN_ACCURACY_REPORT="$PWD/bench/results/accuracy.json" \
  build/ci/tests/kiln_tests_stress
build/ci/bench/kiln-shading-study bench/results/shading_study.json
build/ci/compiler/kiln build variants/lit.pack.json -o build/ci/packs/lit --cache build/ci/kiln-cache -q
build/ci/compiler/kiln build variants/debug.pack.json -o build/ci/packs/debug --cache build/ci/kiln-cache -q
build/ci/bench/kiln-frame-cost build/ci/packs/lit bench/results/frame_cost.json
bash bench/remote_cache.sh build/ci/compiler/kiln . 3
python3 bench/remote_transfers.py --kiln build/ci/compiler/kiln --rounds 3 --delay-ms 5
# kiln against the 2-wide anchors (xargs, build.ninja, glslc): the longest instrument, about 25 minutes.
python3 bench/anchors.py --kiln build/ci/compiler/kiln --reps 3 --floor-tool build/ci/bench/kiln-compile-steps
python3 bench/report.py
echo "wrote bench/results/REPORT.generated.md"
