#!/usr/bin/env bash
# package.deb: `cpack -G DEB` makes one package whose Depends and contents are right, and the consumer project of
# tests/cmake_consumer builds a pack and loads it against that package alone, unpacked with dpkg-deb -x (no root,
# nothing installed on the machine). package.fresh_debian installs it with apt into a fresh Debian 12 instead.
# usage: run_package_test.sh <kiln source dir> <kiln build dir>
set -euo pipefail
source=$1 build=$2
work=$(mktemp -d /tmp/kiln-package-XXXXXX)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }

(cd "$work" && cpack -G DEB --config "$build/CPackConfig.cmake" -B "$work/out" > "$work/cpack.log" 2>&1) ||
  { cat "$work/cpack.log"; fail "cpack -G DEB failed"; }
deb=$(ls "$work"/out/kiln_*.deb)
echo "== $(basename "$deb")"

echo "== Depends: the executables' shared libraries (dpkg-shlibdeps) and what find_package(kiln) needs"
depends=$(dpkg-deb -f "$deb" Depends)
echo "$depends"
names=$(tr ',|' '\n\n' <<< "$depends" | sed 's/^ *//; s/ .*//')
for package in libc6 libstdc++6 libcurl4 libssl3 libzstd1 libxxhash0 libmimalloc2.0 libvulkan1 libegl1 libpng16-16 \
               libxxhash-dev libzstd-dev pkgconf; do
  grep -qxF "$package" <<< "$names" || fail "Depends has no $package"
done

echo "== contents: everything cmake --install installs, under /usr"
contents=$(dpkg-deb -c "$deb" | awk '{print $6}')
for file in ./usr/bin/kiln ./usr/bin/kiln-worker ./usr/bin/kiln-verify ./usr/lib/libkiln_reader.a \
            ./usr/include/kiln/pack_reader.hpp ./usr/include/kiln/manifest.hpp ./usr/include/kiln/kiln_reader.h \
            ./usr/lib/pkgconfig/kiln-reader.pc \
            ./usr/lib/cmake/kiln/kilnConfig.cmake ./usr/lib/cmake/kiln/kilnConfigVersion.cmake \
            ./usr/lib/cmake/kiln/kilnTargets.cmake ./usr/lib/cmake/kiln/KilnShaderPack.cmake \
            ./usr/share/kiln/schema/pack.schema.json ./usr/share/kiln/schema/scene.schema.json \
            ./usr/share/man/man1/kiln.1 ./usr/share/bash-completion/completions/kiln ./usr/share/doc/kiln/lint.md \
            ./usr/share/doc/kiln/README.md ./usr/share/doc/kiln/examples/README.md \
            ./usr/share/doc/kiln/examples/vulkan_triangle/triangle.c ./usr/share/doc/kiln/examples/remote_cache/evict.sh; do
  grep -qxF "$file" <<< "$contents" || fail "the package has no $file"
done
! grep -q "^\./usr/local\|^\./tmp\|^\./work" <<< "$contents" || fail "files outside /usr: $(grep "^\./usr/local\|^\./tmp\|^\./work" <<< "$contents")"

echo "== unpacked: kiln runs from it and a consumer project builds against it"
dpkg-deb -x "$deb" "$work/root"
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
