#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Builds and runs the consumer project, then checks incremental behaviour:
#   touching an included HLSL file rebuilds the pack; touching an unrelated file does not; a new header that
#   shadows an include (found earlier in the search order) rebuilds the pack; changing the scene list changes it.
# subdirectory-configure: add_subdirectory(kiln) configured, and only the reader a game links built (the whole build
# is the subdirectory mode's, label full): the same checks of what kiln configures as a subproject.
# usage: run_consumer_test.sh <find_package|subdirectory|subdirectory-configure> <generator> <kiln source dir> <kiln build dir>
set -euo pipefail
mode=$1 generator=$2 source=$3 build=$4
configure_only=false
if [ "$mode" = subdirectory-configure ]; then mode=subdirectory configure_only=true; fi
work=$(mktemp -d /tmp/kiln-consumer-XXXXXX)
trap 'rm -rf "$work"' EXIT
# The shader library is copied so that the test can touch its files without touching the checkout.
cp -r "$source/shaderlib" "$source/variants" "$work/"
mkdir "$work/kiln-src"
for entry in CMakeLists.txt CMakePresets.json compiler cmake tests bench; do ln -s "$source/$entry" "$work/kiln-src/$entry"; done
ln -s "$work/shaderlib" "$work/kiln-src/shaderlib"
ln -s "$work/variants" "$work/kiln-src/variants"
# The Forward pass includes Fog.hlsl by its name alone: it is looked for next to passes/LitForward.hlsl first (not
# there), then found in the include root. A Fog.hlsl that appears in passes/ later takes its place.
sed -i 's|#include "../Fog.hlsl"|#include "Fog.hlsl"|' "$work/shaderlib/passes/LitForward.hlsl"
grep -q '#include "Fog.hlsl"' "$work/shaderlib/passes/LitForward.hlsl"
extra=(-DCMAKE_BUILD_TYPE=Release)
# kiln inside the consumer builds as a unity build (CMAKE_UNITY_BUILD, which kiln supports): a quarter less CPU
# than one source at a time, and the mode a project that builds its dependencies this way uses. It builds in
# CMake's default configuration (no CMAKE_BUILD_TYPE: no optimization flags), what a game that sets none gets;
# the find_package modes use the ci preset's Release build. Compiling kiln is nearly all of this test's time;
# without -O3 it takes about a fifth less CPU (this test, interleaved runs on a noisy machine: 156 and 216
# CPU-s against Release's 204, 240 and 252).
if [ "$mode" = subdirectory ]; then extra=(-DCMAKE_UNITY_BUILD=ON); fi
if [ "$mode" = find_package ]; then
  cmake --install "$build" --prefix "$work/prefix" > /dev/null
  extra+=(-DCMAKE_PREFIX_PATH="$work/prefix")
fi
cmake -S "$source/tests/cmake_consumer" -B "$work/build" -G "$generator" \
  -DKILN_CONSUMER_MODE="$mode" -DKILN_SOURCE_DIR="$work/kiln-src" \
  -DKILN_CONSUMER_SCENES="$work/variants/scenes/mobile.json" "${extra[@]}" > "$work/configure.log"
if $configure_only; then
  echo "== add_subdirectory(kiln), configured: no verify/ (Vulkan, EGL, PNG, OpenEXR), tests or benchmarks"
  ! grep -q "^KILN_BUILD_VERIFY:BOOL=ON\|^Vulkan_LIBRARY\|^OpenEXR_DIR" "$work/build/CMakeCache.txt" ||
    { echo "FAIL: add_subdirectory(kiln) configured verify/"; exit 1; }
  targets=$(ninja -C "$work/build" -t targets all | cut -d: -f1)
  for target in kiln kiln-worker kiln_reader consumer lit_pack; do
    grep -qx "$target" <<< "$targets" || { echo "FAIL: no target $target"; exit 1; }
  done
  ! grep -qx "kiln-verify\|kiln-reference\|kiln_tests_.*\|kiln-.*-bench" <<< "$targets" ||
    { echo "FAIL: verify/, tests or benchmarks configured"; exit 1; }
  echo "== the reader builds in the game's unity build without a warning"
  cmake --build "$work/build" --target kiln_reader -j 2 > "$work/build1.log"
  ! grep -q "warning:" "$work/build1.log" || { grep -A3 "warning:" "$work/build1.log"; echo "FAIL: the reader warned"; exit 1; }
  echo "consumer test passed (subdirectory, configured; the reader built)"
  exit 0
fi
cmake --build "$work/build" -j 2 > "$work/build1.log"
"$work/build/consumer"
manifest=$(find "$work/build" -name lit.manifest.json -path '*lit_pack*')
test -f "$manifest"

echo "== install: the manifest and the archive it names, nothing else"
cmake --install "$work/build" --prefix "$work/installed" > /dev/null
installed=$(ls "$work/installed/share/kiln_consumer")
named=$(python3 -c 'import json, sys; print(json.load(open(sys.argv[1]))["archive"]["file"])' "$manifest")
[ "$installed" = "$(printf '%s\n' "$named" lit.manifest.json | sort)" ] || { echo "FAIL: installed: $installed"; exit 1; }
cmp "$work/installed/share/kiln_consumer/$named" "$(dirname "$manifest")/$named"
if [ "$mode" = subdirectory ]; then
  echo "== add_subdirectory(kiln): nothing of kiln installed, no verify/ (Vulkan, EGL, PNG, OpenEXR) configured or built"
  others=$(cd "$work/installed" && find . -type f ! -path './share/kiln_consumer/*')
  [ -z "$others" ] || { echo "FAIL: kiln installed into the consumer's tree: $others"; exit 1; }
  ! grep -q "^KILN_BUILD_VERIFY:BOOL=ON\|^Vulkan_LIBRARY\|^OpenEXR_DIR" "$work/build/CMakeCache.txt" ||
    { echo "FAIL: add_subdirectory(kiln) configured verify/"; exit 1; }
  ! grep -q "kiln_verify\|kiln-verify" "$work/build1.log" || { echo "FAIL: add_subdirectory(kiln) built verify/"; exit 1; }
  ! grep -q "warning:" "$work/build1.log" || { grep -A3 "warning:" "$work/build1.log"; echo "FAIL: the unity build warned"; exit 1; }
fi

stamp() { stat -c %Y.%y "$manifest"; }
rebuilds() { cmake --build "$work/build" -j 2 2>&1 | tee "$work/last.log" | grep -c "kiln: building shader pack" || true; }

echo "== no change: nothing is rebuilt"
[ "$(rebuilds)" = 0 ] || { cat "$work/last.log"; echo "FAIL: a no-change build rebuilt the pack"; exit 1; }

echo "== an unrelated file changes: nothing is rebuilt"
sleep 1.1; touch "$work/shaderlib/README.md"
[ "$(rebuilds)" = 0 ] || { cat "$work/last.log"; echo "FAIL: touching an unrelated file rebuilt the pack"; exit 1; }

echo "== an included file changes: the pack is rebuilt"
before=$(stamp)
sleep 1.1; echo "// edited by the consumer test" >> "$work/shaderlib/Fog.hlsl"
[ "$(rebuilds)" = 1 ] || { cat "$work/last.log"; echo "FAIL: editing Fog.hlsl did not rebuild the pack"; exit 1; }
[ "$(stamp)" != "$before" ] || { echo "FAIL: the pack was not rewritten"; exit 1; }
"$work/build/consumer" > /dev/null

echo "== a new header shadows an include: the pack is rebuilt"
before=$(stamp)
sleep 1.1; { echo "// the shadowing copy"; cat "$work/shaderlib/Fog.hlsl"; } > "$work/shaderlib/passes/Fog.hlsl"
[ "$(rebuilds)" = 1 ] || { cat "$work/last.log"; echo "FAIL: a Fog.hlsl new in passes/ did not rebuild the pack"; exit 1; }
[ "$(stamp)" != "$before" ] || { echo "FAIL: the pack was not rewritten"; exit 1; }
[ "$(rebuilds)" = 0 ] || { cat "$work/last.log"; echo "FAIL: the build after it rebuilt the pack again"; exit 1; }

echo "== the scene list changes: the pack changes"
variants_before=$("$work/build/consumer" | head -1)
cmake "$work/build" -DKILN_CONSUMER_SCENES="$work/variants/scenes/mobile.json;$work/variants/scenes/night_city.json" > /dev/null
[ "$(rebuilds)" = 1 ] || { cat "$work/last.log"; echo "FAIL: changing the scenes did not rebuild the pack"; exit 1; }
variants_after=$("$work/build/consumer" | head -1)
[ "$variants_before" != "$variants_after" ] || { echo "FAIL: the pack did not change ($variants_after)"; exit 1; }
echo "$variants_before -> $variants_after"
echo "consumer test passed ($mode, $generator)"
