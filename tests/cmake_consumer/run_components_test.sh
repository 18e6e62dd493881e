#!/usr/bin/env bash
# find_package(kiln) with one of the two Debian packages' parts installed (cmake --install --component, as the
# packages split it: cli is the kiln package, reader and dev the reader's):
#   the compiler's part alone gives kiln::kiln and kiln_add_shader_pack, and a project that needs the reader is told
#   which package holds it; the reader's part alone gives kiln::reader, and kiln_add_shader_pack or a project that
#   needs the compiler is told to install the kiln package (not CMake's "Unknown CMake command").
# usage: run_components_test.sh <kiln build dir>
set -euo pipefail
build=$1
work=$(mktemp -d "${TMPDIR:-/tmp}/kiln-components-XXXXXX")
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
cmake --install "$build" --component cli --prefix "$work/compiler" > /dev/null
for component in reader dev; do cmake --install "$build" --component $component --prefix "$work/reader" > /dev/null; done

project() {  # directory, body: a project that does only what body says
  mkdir -p "$work/$1"
  printf 'cmake_minimum_required(VERSION 3.25)\nproject(consumer LANGUAGES NONE)\n%s\n' "$2" > "$work/$1/CMakeLists.txt"
}
said() {  # directory, text: the configure's output says text (CMake wraps its messages: compared with words joined)
  tr -s ' \n' '  ' < "$work/$1.log" | grep -qF "$2"
}
configure() {  # directory, prefix: the configure's output; its exit status in $status
  status=0
  cmake -S "$work/$1" -B "$work/$1/build" -DCMAKE_PREFIX_PATH="$work/$2" > "$work/$1.log" 2>&1 || status=$?
}

echo "== the kiln package alone: the compiler, and the reader's package named"
project compiler-only 'find_package(kiln REQUIRED)
if(NOT TARGET kiln::kiln OR NOT COMMAND kiln_add_shader_pack OR NOT EXISTS "${KILN_SCHEMA_DIR}/pack.schema.json")
  message(FATAL_ERROR "no compiler component")
endif()
message(STATUS "compiler ${kiln_compiler_FOUND}, reader ${kiln_reader_FOUND}")'
configure compiler-only compiler
[ $status -eq 0 ] || { cat "$work/compiler-only.log"; fail "find_package(kiln) with the kiln package alone"; }
grep -q "compiler TRUE, reader FALSE" "$work/compiler-only.log" || { cat "$work/compiler-only.log"; fail "components"; }
project needs-reader 'find_package(kiln REQUIRED COMPONENTS reader)'
configure needs-reader compiler
[ $status -ne 0 ] || fail "find_package(kiln COMPONENTS reader) succeeded without the reader"
said needs-reader "(apt install libkiln-reader-dev)" || { cat "$work/needs-reader.log"; fail "no package named for the reader"; }

echo "== the reader's packages alone: the reader, and the kiln package named"
project reader-only 'find_package(kiln REQUIRED)
if(NOT TARGET kiln::reader OR TARGET kiln::kiln)
  message(FATAL_ERROR "not the reader alone")
endif()
kiln_add_shader_pack(lit_pack PACK lit.pack.json)'
configure reader-only reader
[ $status -ne 0 ] || fail "kiln_add_shader_pack without the compiler configured"
said reader-only "kiln_add_shader_pack needs the kiln compiler, which is not installed: it is in the Debian package kiln (apt install kiln)" || { cat "$work/reader-only.log"; fail "kiln_add_shader_pack did not name the package"; }
! grep -q "Unknown CMake command" "$work/reader-only.log" || fail "Unknown CMake command"
project needs-compiler 'find_package(kiln REQUIRED COMPONENTS compiler)'
configure needs-compiler reader
[ $status -ne 0 ] || fail "find_package(kiln COMPONENTS compiler) succeeded without the compiler"
said needs-compiler "the kiln compiler (kiln::kiln, kiln_add_shader_pack) is not installed: it is in the Debian package kiln (apt install kiln)" ||
  { cat "$work/needs-compiler.log"; fail "no package named for the compiler"; }
echo "PASS"
