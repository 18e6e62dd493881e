#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# kiln_add_shader_pack's options and checks, and a cross build, on an installed kiln:
#   the schemas are installed; OPTIONS, DEPENDS, EXCLUDE_FROM_ALL and generator expressions in paths work;
#   mistakes are configure errors with a clear message (a path known only at build time: a build error);
#   a cross build (toolchain file, fake sysroot whose kiln cannot run) runs the host kiln from KILN_EXECUTABLE;
#   the installed examples (share/doc/kiln/examples) build against the installed kiln and draw.
# usage: run_cmake_api_test.sh <generator> <kiln source dir> <kiln build dir>
set -euo pipefail
generator=$1 source=$2 build=$3
work=$(mktemp -d "${TMPDIR:-/tmp}/kiln-cmake-api-XXXXXX")
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
cmake --install "$build" --prefix "$work/prefix" > /dev/null

echo "== the man page and bash completion are installed"
gzip -dc "$work/prefix/share/man/man1/kiln.1.gz" | cmp - "$source/docs/man/kiln.1" || fail "the man page is not installed (gzip -9n)"
cmp "$work/prefix/share/bash-completion/completions/kiln" "$build/compiler/completion/kiln.bash" ||
  fail "the bash completion is not installed"
echo "== the pack and scene schemas are installed"
for schema in pack.schema.json scene.schema.json; do
  cmp "$work/prefix/share/kiln/schema/$schema" "$source/variants/schema/$schema" || fail "$schema not installed"
done

echo "== the installed examples build against the installed kiln and draw"
examples="$work/prefix/share/doc/kiln/examples"
test -f "$examples/README.md" || fail "the examples are not installed"
cmake -S "$examples" -B "$work/examples" -G "$generator" -DCMAKE_PREFIX_PATH="$work/prefix" > "$work/examples-configure.log" ||
  { cat "$work/examples-configure.log"; fail "the installed examples do not configure"; }
cmake --build "$work/examples" -j 2 > "$work/examples-build.log" 2>&1 || { cat "$work/examples-build.log"; fail "the installed examples do not build"; }
"$work/examples/vulkan_triangle" "$work/examples/packs/vulkan_triangle" "$work/triangle.png" INVERT
python3 "$source/examples/vulkan_triangle/check_png.py" "$work/triangle.png" 0 128 255 || fail "the installed example drew the wrong image"

echo "== OPTIONS, DEPENDS, EXCLUDE_FROM_ALL, generator expressions"
# The packs are stripped to the mobile scene (155 of 1284 variants): what is tested is the module, not a cold
# build of the whole library (the consumer tests and the suite do that).
cmake -S "$source/tests/cmake_consumer" -B "$work/build" -G "$generator" -DCMAKE_BUILD_TYPE=Release \
  -DKILN_SOURCE_DIR="$source" -DCMAKE_PREFIX_PATH="$work/prefix" \
  -DKILN_CONSUMER_SCENES="$source/variants/scenes/mobile.json" > "$work/configure.log"
cmake --build "$work/build" -j 2 > "$work/build.log"
# Each pack has its development-loop target (kiln watch until Ctrl-C: listed, never run here, never part of ALL).
cmake --build "$work/build" --target help > "$work/targets.log"
for watch_target in lit_pack_watch extra_pack_watch; do
  grep -qE "(^|[ .])$watch_target(:| |$)" "$work/targets.log" || { cat "$work/targets.log"; fail "no $watch_target target"; }
done
! grep -q "kiln: watching" "$work/build.log" || fail "the default build ran a _watch target"
extra="$work/build/extra/release/lit.manifest.json"
[ ! -e "$extra" ] || fail "EXCLUDE_FROM_ALL: extra_pack was built by the default build"
[ ! -e "$work/build/prerequisite.stamp" ] || fail "the prerequisite ran without extra_pack"
cmake --build "$work/build" --target extra_pack -j 2 > "$work/extra.log" || { cat "$work/extra.log"; fail "extra_pack"; }
[ -e "$work/build/prerequisite.stamp" ] || fail "DEPENDS: the prerequisite target did not run before extra_pack"
test -f "$extra" || fail "OUTPUT_DIR with \$<CONFIG>: no $extra"
python3 - "$extra" <<'PY' || fail "OPTIONS --targets spirv or the generator-expression scene did not reach kiln"
import json, sys
m = json.load(open(sys.argv[1]))
targets = {t for b in m["binaries"] for t in b["blobs"]}
assert targets == {"spirv"}, targets
forward = next(p for p in m["passes"] if p["name"] == "Forward")
keywords = {k for v in forward["variants"] for k in v["keywords"]}
assert "_MAIN_LIGHT_SHADOWS_CASCADE" not in keywords, "the mobile scene was not applied"
PY

echo "== USAGE: the pack keeps what the usage log asked for, and a changed log rebuilds it"
cat > "$work/usage.json" <<'JSON'
{"format": "kiln-usage", "format_version": 1, "pack": "lit", "tags": {},
 "passes": [{"name": "Forward", "served": [{"keywords": ["_MAIN_LIGHT_SHADOWS"], "count": 7}], "missing": []}],
 "missing_dropped": 0}
JSON
cmake "$work/build" -DKILN_CONSUMER_USAGE_LOG="$work/usage.json" > /dev/null
cmake --build "$work/build" --target usage_pack -j 2 > "$work/usage.log" 2>&1 || { cat "$work/usage.log"; fail "usage_pack"; }
usage_variants() { python3 -c 'import json,sys; m=json.load(open(sys.argv[1])); print(sorted(" ".join(v["keywords"]) for p in m["passes"] if p["name"]=="Forward" for v in p["variants"]))' "$work/build/usage/lit.manifest.json"; }
[ "$(usage_variants)" = "['_MAIN_LIGHT_SHADOWS']" ] || fail "USAGE: the Forward pass kept $(usage_variants)"
sed -i 's/"_MAIN_LIGHT_SHADOWS"\]/"FOG_EXP2", "_MAIN_LIGHT_SHADOWS"]/' "$work/usage.json"
cmake --build "$work/build" --target usage_pack -j 2 > "$work/usage.log" 2>&1 || { cat "$work/usage.log"; fail "usage_pack again"; }
[ "$(usage_variants)" = "['FOG_EXP2 _MAIN_LIGHT_SHADOWS']" ] || fail "a changed usage log did not rebuild the pack: $(usage_variants)"

echo "== mistakes are reported with a clear message"
expect_configure_error() {  # case, expected text, extra cmake arguments...
  local case=$1 text=$2; shift 2
  if cmake -S "$source/tests/cmake_consumer/errors" -B "$work/errors-$case" -G "$generator" -DKILN_ERROR_CASE="$case" \
       -DKILN_SOURCE_DIR="$source" -DCMAKE_PREFIX_PATH="$work/prefix" "$@" > "$work/errors-$case.log" 2>&1; then
    fail "$case: configured without an error"
  fi
  grep -qF "$text" <<< "$(tr -s ' \n' ' ' < "$work/errors-$case.log")" || { cat "$work/errors-$case.log"; fail "$case: no '$text'"; }
  echo "ok: $case"
}
expect_configure_error missing_pack \
  "kiln_add_shader_pack(p): pack definition '$source/tests/cmake_consumer/errors/missing.pack.json' does not exist (PACK missing.pack.json)"
expect_configure_error missing_scene \
  "kiln_add_shader_pack(p): scene profile '$source/tests/cmake_consumer/errors/missing-scene.json' does not exist (SCENES missing-scene.json)"
expect_configure_error genex_pack_without_name "give the pack's name with NAME <name>"
expect_configure_error install_unknown_target \
  "kiln_install_shader_pack(no_such_target): no target named 'no_such_target' (make it with kiln_add_shader_pack first)"
expect_configure_error install_wrong_target \
  "kiln_install_shader_pack(not_a_pack): 'not_a_pack' is not a shader pack: only a target made by kiln_add_shader_pack can be installed this way"
# A path with a generator expression is known at build time only: kiln reports it there.
cmake -S "$source/tests/cmake_consumer/errors" -B "$work/errors-genex" -G "$generator" -DKILN_ERROR_CASE=missing_genex_scene \
  -DKILN_SOURCE_DIR="$source" -DCMAKE_PREFIX_PATH="$work/prefix" > "$work/errors-genex.log"
if cmake --build "$work/errors-genex" > "$work/errors-genex-build.log" 2>&1; then fail "missing_genex_scene: built"; fi
# The build tool (a dependency of the pack's command) or kiln (--scene) names the missing file.
grep -qF -- "$source/tests/cmake_consumer/errors/missing-scene.json" "$work/errors-genex-build.log" ||
  { cat "$work/errors-genex-build.log"; fail "missing_genex_scene: no clear build error"; }
echo "ok: missing_genex_scene (at build time)"

echo "== a cross build runs the host kiln (KILN_EXECUTABLE), never the sysroot's"
mkdir -p "$work/sysroot"
cp -a "$work/prefix" "$work/sysroot/usr"
# The target's kiln: running it on the build machine is the bug this guards against.
printf '#!/bin/sh\ntouch "%s"\necho "the target sysroot'"'"'s kiln ran on the build machine" >&2\nexit 99\n' "$work/target-kiln-ran" \
  > "$work/sysroot/usr/bin/kiln"
export KILN_FAKE_SYSROOT="$work/sysroot"
toolchain="$source/tests/cmake_consumer/cross-toolchain.cmake"
expect_configure_error cross_without_host_kiln \
  "kiln_add_shader_pack: cross-compiling (CMAKE_SYSTEM_NAME Linux): set the KILN_EXECUTABLE cache variable to a kiln that runs on this machine" \
  -DCMAKE_TOOLCHAIN_FILE="$toolchain" -DCMAKE_PREFIX_PATH=/usr
cmake -S "$source/tests/cmake_consumer" -B "$work/cross" -G "$generator" -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_TOOLCHAIN_FILE="$toolchain" -DCMAKE_PREFIX_PATH=/usr -DKILN_CONSUMER_PACK_ONLY=ON \
  -DKILN_SOURCE_DIR="$source" -DKILN_CONSUMER_SCENES="$source/variants/scenes/mobile.json" \
  -DKILN_EXECUTABLE="$build/compiler/kiln" > "$work/cross-configure.log"
grep -q "kiln_consumer: CMAKE_CROSSCOMPILING=TRUE" "$work/cross-configure.log" || fail "the toolchain did not make a cross build"
cmake --build "$work/cross" -j 2 > "$work/cross-build.log" 2>&1 || { cat "$work/cross-build.log"; fail "cross build"; }
[ ! -e "$work/target-kiln-ran" ] || fail "the sysroot's kiln ran"
test -f "$work/cross/lit_pack/lit.manifest.json" || fail "cross build: no pack"
echo "cmake api test passed ($generator)"
