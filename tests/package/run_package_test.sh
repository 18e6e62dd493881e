#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# package.deb: `cpack -G DEB` makes the four packages of cmake/KilnPackaging.cmake, each with the right Depends and
# contents and no lintian error; then, against those packages alone, unpacked with dpkg-deb -x (no root, nothing
# installed on the machine): a C program built with the C compiler and pkg-config, a CMake project with LANGUAGES C,
# and the consumer project of tests/cmake_consumer (find_package, kiln_add_shader_pack, the C++ reader).
# package.fresh_debian installs them with apt into a fresh Debian 12 instead.
# usage: run_package_test.sh <kiln source dir> <kiln build dir>
set -euo pipefail
# (No `... | grep -q` here: grep exits at its first match, the writer's next write dies of SIGPIPE, and pipefail
# fails the pipeline; matches are read whole, `grep ... > /dev/null`.)
source=$1 build=$2
work=$(mktemp -d /tmp/kiln-package-XXXXXX)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }

(cd "$work" && cpack -G DEB --config "$build/CPackConfig.cmake" -B "$work/out" > "$work/cpack.log" 2>&1) ||
  { cat "$work/cpack.log"; fail "cpack -G DEB failed"; }
deb() { ls "$work"/out/"$1"_*.deb 2> /dev/null || fail "cpack made no $1 package: $(ls "$work/out")"; }
names_of() { tr ',|' '\n\n' <<< "$1" | sed 's/^ *//; s/ .*//'; }
for package in libkiln-reader0 libkiln-reader-dev kiln kiln-verify; do echo "== $(basename "$(deb $package)")"; done

echo "== Depends: each package's shared libraries (dpkg-shlibdeps) and the packages below it, nothing more"
expect_depends() {  # package, then +name (must be there) or -name (must not)
  local package=$1 depends names
  shift
  depends=$(dpkg-deb -f "$(deb "$package")" Depends)
  echo "$package: $depends"
  names=$(names_of "$depends")
  for want in "$@"; do
    case $want in
      +*) grep -qxF "${want#+}" <<< "$names" || fail "$package: Depends has no ${want#+}" ;;
      -*) ! grep -qxF "${want#-}" <<< "$names" || fail "$package: Depends has ${want#-}" ;;
    esac
  done
}
expect_depends libkiln-reader0 +libc6 +libstdc++6 +libzstd1 +libxxhash0 -libvulkan1 -libcurl4
expect_depends libkiln-reader-dev +libkiln-reader0 +libxxhash-dev +libzstd-dev -libcurl4-openssl-dev -libcurl4
grep -q "libcurl4-openssl-dev" <<< "$(dpkg-deb -f "$(deb libkiln-reader-dev)" Suggests)" ||
  fail "libkiln-reader-dev does not suggest libcurl's development files (kiln::reader_dev links libcurl)"
expect_depends kiln +libc6 +libstdc++6 +libcurl4 +libssl3 +libzstd1 +libmimalloc2.0 \
  -libvulkan1 -libegl1 -libpng16-16 -libgl1 -libx11-6 -libkiln-reader-dev -libxxhash-dev
expect_depends kiln-verify +kiln +libvulkan1 +libegl1 +libpng16-16
grep -q "(= $(dpkg-deb -f "$(deb kiln)" Version))" <<< "$(dpkg-deb -f "$(deb kiln-verify)" Depends)" ||
  fail "kiln-verify does not depend on this version of kiln"
dpkg-deb --ctrl-tarfile "$(deb libkiln-reader0)" | tar -t | grep -x "./shlibs" > /dev/null || fail "libkiln-reader0 has no shlibs file"

echo "== contents: each package holds its part of what cmake --install installs, under /usr"
expect_files() {  # package, files
  local package=$1 contents
  shift
  contents=$(dpkg-deb -c "$(deb "$package")" | awk '{print $6}')
  for file in "$@" ./usr/share/doc/$package/copyright ./usr/share/doc/$package/changelog.Debian.gz; do
    grep -qxF "$file" <<< "$contents" || fail "$package has no $file"
  done
  ! grep -q "^\./usr/local\|^\./tmp\|^\./work" <<< "$contents" || fail "$package: files outside /usr"
}
expect_files libkiln-reader0 ./usr/lib/libkiln_reader.so.0 ./usr/lib/libkiln_reader.so.0.2.0
expect_files libkiln-reader-dev ./usr/lib/libkiln_reader.so ./usr/lib/libkiln_reader.a ./usr/lib/pkgconfig/kiln-reader.pc \
  ./usr/include/kiln/pack_reader.hpp ./usr/include/kiln/manifest.hpp ./usr/include/kiln/kiln_reader.h \
  ./usr/include/kiln/folded_keywords.hpp ./usr/include/kiln/keyword_kinds.def ./usr/include/kiln/coverage_map.hpp \
  ./usr/lib/cmake/kiln/kilnConfig.cmake ./usr/lib/cmake/kiln/kilnConfigVersion.cmake ./usr/lib/cmake/kiln/kilnReaderTargets.cmake \
  ./usr/lib/libkiln_reader_dev.a ./usr/lib/pkgconfig/kiln-reader-dev.pc ./usr/lib/cmake/kiln/kilnReaderDevTargets.cmake \
  ./usr/include/kiln/development_reader.hpp ./usr/include/kiln/kiln_reader_dev.h ./usr/include/kiln/development_endpoint.hpp
expect_files kiln ./usr/bin/kiln ./usr/bin/kiln-worker \
  ./usr/lib/cmake/kiln/kilnCompilerTargets.cmake ./usr/lib/cmake/kiln/KilnShaderPack.cmake \
  ./usr/share/kiln/schema/pack.schema.json ./usr/share/kiln/schema/scene.schema.json \
  ./usr/share/man/man1/kiln.1.gz ./usr/share/bash-completion/completions/kiln ./usr/share/doc/kiln/lint.md \
  ./usr/share/doc/kiln/README.md ./usr/share/doc/kiln/examples/README.md \
  ./usr/share/doc/kiln/examples/vulkan_triangle/triangle.c ./usr/share/doc/kiln/examples/remote_cache/evict.sh
expect_files kiln-verify ./usr/bin/kiln-verify ./usr/share/man/man1/kiln-verify.1.gz
# find_package(kiln) with the kiln package alone (kiln-config.cmake), and every page the man page cites.
expect_files kiln ./usr/lib/cmake/kiln/kiln-config.cmake ./usr/lib/cmake/kiln/kiln-config-version.cmake \
  ./usr/share/man/man1/kiln-worker.1.gz ./usr/share/doc/kiln/changelog.gz \
  $(grep -o 'docs/[a-z_-]*\.md' "$source/docs/man/kiln.1" | sort -u | sed 's|^docs/|./usr/share/doc/kiln/|')
grep -q "pkgconf" <<< "$(dpkg-deb -f "$(deb libkiln-reader-dev)" Depends)" || fail "libkiln-reader-dev does not depend on pkgconf"
grep -q "libstdc++" <<< "$(dpkg-deb -f "$(deb libkiln-reader-dev)" Depends)" ||
  fail "libkiln-reader-dev does not depend on the C++ runtime's development files (pkg-config --static needs libstdc++.a)"
for package in libkiln-reader0 libkiln-reader-dev kiln-verify; do
  ! dpkg-deb -c "$(deb $package)" | awk '{print $6}' | grep "^\./usr/bin/kiln$" > /dev/null || fail "$package holds kiln"
done

echo "== lintian: no errors"
lintian --no-tag-display-limit "$work"/out/*.deb > "$work/lintian.txt" 2>&1 || true
cat "$work/lintian.txt"
! grep -q "^E: " "$work/lintian.txt" || fail "lintian reports errors"

echo "== the shared reader exports the C API and namespace kiln only"
dpkg-deb -x "$(deb libkiln-reader0)" "$work/root"
# (Symbols of namespace kiln, and the standard library's templates instantiated with kiln's types, whose mangled
# names hold 4kiln; none of nlohmann-json's, xxHash's, zstd's or the standard library's own.)
others=$(nm -D --defined-only "$work/root/usr/lib/libkiln_reader.so.0" | awk '{print $3}' |
         grep -v '^kiln_\|4kiln\|^KILN_READER_0$' || true)
[ -z "$others" ] || fail "libkiln_reader.so.0 exports more than kiln's API: $(head -5 <<< "$others")"
objdump -p "$work/root/usr/lib/libkiln_reader.so.0" | grep "SONAME *libkiln_reader.so.0$" > /dev/null || fail "no SONAME libkiln_reader.so.0"
! objdump -p "$work/root/usr/lib/libkiln_reader.so.0" | grep "NEEDED.*libcurl" > /dev/null || fail "the release reader needs libcurl"

echo "== the reader's developer package alone: gcc links a C program, a LANGUAGES C CMake project links kiln::reader"
dpkg-deb -x "$(deb libkiln-reader-dev)" "$work/root"
[ ! -e "$work/root/usr/bin/kiln" ] || fail "the reader's packages hold kiln"
# (the pack comes from the build tree's kiln: the CLI is not unpacked yet)
"$build/compiler/kiln" build "$source/tests/capi/tiny.pack.json" -o "$work/pack" --no-cache -q
cat > "$work/game.c" <<'C'
#include <stdio.h>
#include <kiln/kiln_reader.h>
int main(int argc, char** argv) {
  kiln_error error;
  kiln_pack* pack;
  kiln_pass pass;
  if (argc != 2 || kiln_pack_open(argv[1], &pack, &error) != KILN_OK || kiln_pass_find(pack, "Main", &pass, &error) != KILN_OK) {
    fprintf(stderr, "%s: %s\n", error.file, error.message);
    return 1;
  }
  printf("%s: %u variants of %s\n", kiln_pack_name(pack), (unsigned)kiln_variant_count(pack, pass), kiln_pass_name(pack, pass));
  kiln_pack_close(pack);
  return 0;
}
C
flags=$(PKG_CONFIG_PATH="$work/root/usr/lib/pkgconfig" pkg-config --cflags --libs kiln-reader)
echo "pkg-config --cflags --libs kiln-reader: $flags"
! grep -q "stdc++" <<< "$flags" || fail "pkg-config names the C++ runtime for the shared reader"
gcc -std=c11 -Wall -Wextra -pedantic -Werror -o "$work/game" "$work/game.c" $flags || fail "gcc cannot link the reader"
LD_LIBRARY_PATH="$work/root/usr/lib" "$work/game" "$work/pack" | tee "$work/game.txt"
grep -qE '^tiny: [1-9][0-9]* variants of Main$' "$work/game.txt" || fail "the C program's output"
mkdir "$work/c-project"
cp "$work/game.c" "$work/c-project/"
cat > "$work/c-project/CMakeLists.txt" <<'CMAKE'
cmake_minimum_required(VERSION 3.25)
project(c_game LANGUAGES C)
find_package(kiln REQUIRED COMPONENTS ${KILN_COMPONENTS})
add_executable(game game.c)
target_link_libraries(game PRIVATE kiln::reader)
CMAKE
cmake -S "$work/c-project" -B "$work/c-build" -G Ninja -DCMAKE_PREFIX_PATH="$work/root/usr" -DKILN_COMPONENTS=reader \
  > "$work/c-configure.log" 2>&1 || { cat "$work/c-configure.log"; fail "a LANGUAGES C project cannot find_package(kiln)"; }
cmake --build "$work/c-build" > "$work/c-build.log" 2>&1 || { cat "$work/c-build.log"; fail "a LANGUAGES C project cannot link kiln::reader"; }
"$work/c-build/game" "$work/pack" > /dev/null || fail "the LANGUAGES C program failed"
# The compiler's part is the kiln package's: asked for without it, find_package says so.
! cmake -S "$work/c-project" -B "$work/c-build2" -G Ninja -DCMAKE_PREFIX_PATH="$work/root/usr" -DKILN_COMPONENTS=compiler \
  > "$work/c-configure2.log" 2>&1 || fail "find_package(kiln COMPONENTS compiler) succeeded without the kiln package"
grep -q "compiler" "$work/c-configure2.log" || { cat "$work/c-configure2.log"; fail "find_package does not name the missing part"; }

echo "== with kiln and kiln-verify: kiln runs from the unpacked tree, the consumer project builds"
for package in kiln kiln-verify; do dpkg-deb -x "$(deb $package)" "$work/root"; done
# With the compiler's part installed, find_package(kiln) loads it in a LANGUAGES C project too.
cmake -S "$work/c-project" -B "$work/c-build3" -G Ninja -DCMAKE_PREFIX_PATH="$work/root/usr" -DKILN_COMPONENTS="reader;compiler" \
  > "$work/c-configure3.log" 2>&1 || { cat "$work/c-configure3.log"; fail "find_package(kiln COMPONENTS reader compiler) failed"; }
"$work/root/usr/bin/kiln" --version | head -1
# SARIF's help links point into the package's own docs (the unpacked tree stands for /usr).
printf 'float4 F() : SV_Target { return 1.0; }\n' > "$work/S.hlsl"
# (into a file first: `grep -q` stops reading at its match, and kiln's next write would die of SIGPIPE under pipefail)
"$work/root/usr/bin/kiln" lint "$work/S.hlsl" --format sarif > "$work/S.sarif" || fail "kiln lint failed"
grep -qF "file://$work/root/usr/share/doc/kiln/lint.md#" "$work/S.sarif" ||
  fail "SARIF helpUri does not point at the package's lint.md: $(grep -o '"helpUri": *"[^"]*"' "$work/S.sarif" | head -1)"
cp -r "$source/shaderlib" "$source/variants" "$work/"
mkdir "$work/kiln-src"
ln -s "$work/variants" "$work/kiln-src/variants"
cmake -S "$source/tests/cmake_consumer" -B "$work/consumer" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DKILN_CONSUMER_MODE=find_package -DKILN_SOURCE_DIR="$work/kiln-src" \
  -DKILN_CONSUMER_SCENES="$work/variants/scenes/mobile.json" -DCMAKE_PREFIX_PATH="$work/root/usr" > "$work/configure.log" ||
  { cat "$work/configure.log"; fail "configuring the consumer failed"; }
grep -qxF "kiln_DIR:PATH=$work/root/usr/lib/cmake/kiln" "$work/consumer/CMakeCache.txt" ||
  fail "find_package(kiln) did not find the unpacked package: $(grep '^kiln_DIR' "$work/consumer/CMakeCache.txt")"
cmake --build "$work/consumer" -j 2 > "$work/build.log" 2>&1 || { cat "$work/build.log"; fail "building the consumer failed"; }
grep -q "$work/root/usr/bin/kiln" "$work/consumer/build.ninja" || fail "the pack was not built by the package's kiln"
"$work/consumer/consumer"
echo "package test passed"
