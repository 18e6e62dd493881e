#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# find_package(kiln) with one of the two Debian packages' parts installed (cmake --install --component, as the
# packages split it: cli is the kiln package, reader and dev the reader's):
#   the compiler's part alone gives kiln::kiln and kiln_add_shader_pack, and a project that needs the reader is told
#   which package holds it; the reader's part alone gives kiln::reader, and kiln_add_shader_pack or a project that
#   needs the compiler is told to install the kiln package (not CMake's "Unknown CMake command"); the reader's part
#   alone gives kiln::reader_dev (COMPONENTS reader_dev) over the shared reader, which needs no libcurl itself, and
#   kiln-reader-dev.pc links the same from cc and c++.
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
project needs-reader-dev 'find_package(kiln REQUIRED COMPONENTS reader_dev)'
configure needs-reader-dev compiler
[ $status -ne 0 ] || fail "find_package(kiln COMPONENTS reader_dev) succeeded without the reader's package"
said needs-reader-dev "(apt install libkiln-reader-dev)" || { cat "$work/needs-reader-dev.log"; fail "no package named for kiln::reader_dev"; }

echo "== the development reader from the reader's packages: kiln::reader_dev over the shared reader, libcurl its own"
mkdir -p "$work/reader-dev"
cat > "$work/reader-dev/game.c" <<'C'
#include <stdio.h>
#include <kiln/kiln_reader_dev.h>
int main(void) {  /* KILN_DEVELOPMENT_ENDPOINT unset: development mode stays off, and nothing connects */
  kiln_development* development = NULL;
  kiln_error error;
  if (kiln_development_from_environment(NULL, "none.manifest.json", &development, &error) != KILN_OK || development) return 1;
  printf("development mode off\n");
  return 0;
}
C
cat > "$work/reader-dev/game.cpp" <<'CPP'
#include <cstdio>
#include <kiln/development_reader.hpp>
int main(int argc, char** argv) {
  kiln::PackResult<kiln::PackReader> reader = kiln::PackReader::try_open(argc > 1 ? argv[1] : "none.manifest.json");
  if (reader) return kiln::DevelopmentReader::from_environment(*reader, argv[1]) ? 1 : 0;
  std::printf("no pack: %s\n", reader.code() == kiln::PackError::Code::Io ? "io" : "other");
  return 0;
}
CPP
cat > "$work/reader-dev/CMakeLists.txt" <<'CMAKE'
cmake_minimum_required(VERSION 3.25)
project(dev_game LANGUAGES C CXX)
find_package(kiln REQUIRED COMPONENTS reader reader_dev)
add_executable(c_game game.c)
target_link_libraries(c_game PRIVATE kiln::reader_dev)
add_executable(cxx_game game.cpp)
target_link_libraries(cxx_game PRIVATE kiln::reader_dev)
CMAKE
configure reader-dev reader
[ $status -eq 0 ] || { cat "$work/reader-dev.log"; fail "find_package(kiln COMPONENTS reader reader_dev) from the reader's packages"; }
cmake --build "$work/reader-dev/build" > "$work/reader-dev-build.log" 2>&1 || { cat "$work/reader-dev-build.log"; fail "kiln::reader_dev does not link"; }
for game in c_game cxx_game; do
  LD_LIBRARY_PATH="$work/reader/lib" "$work/reader-dev/build/$game" > /dev/null || fail "$game failed"
  needed=$(objdump -p "$work/reader-dev/build/$game" | awk '/NEEDED/ {print $2}')
  grep -qx "libkiln_reader.so.0" <<< "$needed" || fail "$game does not link the shared reader: $needed"
  grep -q "^libcurl" <<< "$needed" || fail "$game does not link libcurl: $needed"
  ! nm -C --defined-only "$work/reader-dev/build/$game" | grep -q "kiln::PackReader::try_open" || fail "$game holds a copy of the reader"
done
! objdump -p "$work/reader/lib/libkiln_reader.so.0" | grep -q "NEEDED.*libcurl" || fail "the release reader needs libcurl"
echo "== the same without CMake: kiln-reader-dev.pc, for cc and c++"
flags=$(PKG_CONFIG_PATH="$work/reader/lib/pkgconfig" pkg-config --cflags --libs kiln-reader-dev)
echo "pkg-config --cflags --libs kiln-reader-dev: $flags"
gcc -std=c11 -Wall -Wextra -pedantic -Werror -o "$work/reader-dev/pc_c_game" "$work/reader-dev/game.c" $flags || fail "cc cannot link kiln-reader-dev"
g++ -std=c++20 -Wall -Wextra -Werror -o "$work/reader-dev/pc_cxx_game" "$work/reader-dev/game.cpp" $flags || fail "c++ cannot link kiln-reader-dev"
for game in pc_c_game pc_cxx_game; do
  LD_LIBRARY_PATH="$work/reader/lib" "$work/reader-dev/$game" > /dev/null || fail "$game failed"
done
echo "PASS"
