#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# package.fresh_debian: the Debian packages installed with apt into a fresh, minimal Debian 12 (a debootstrap chroot,
# made as ../shared/tools/fresh-debian.sh makes it), where only their Depends bring kiln's libraries: first kiln and
# the reader alone (nothing of Vulkan, EGL or X11 comes with them; a C program links with gcc alone), then
# kiln-verify and a consumer project (tests/cmake_consumer, find_package mode) that builds a pack with the installed
# kiln and loads it with the installed reader. Needs root (chroot, bind mounts) and the Debian mirror, and takes minutes: label `chroot`, left
# out of the presets' runs; run it with `ctest --test-dir build/ci -L chroot`.
# usage: fresh_debian_test.sh <kiln source dir> <kiln build dir>
set -euo pipefail
source=$1 build=$2
[ "$(id -u)" = 0 ] || { echo "FAIL: needs root (chroot)"; exit 1; }
base=/var/tmp/fresh-debian-base
root=$(mktemp -d /var/tmp/kiln-package-chroot-XXXXXX)
mounted=()
cleanup() {
  for ((i = ${#mounted[@]} - 1; i >= 0; i--)); do umount "${mounted[$i]}" 2>/dev/null || umount -l "${mounted[$i]}"; done
  # Never delete through a bind mount.
  if grep -q " $root/" /proc/mounts; then echo "mounts remain under $root; not removing it" >&2; else rm -rf --one-file-system "$root"; fi
}
trap cleanup EXIT

mirror=$(awk '/^URIs:/{print $2; exit}' /etc/apt/sources.list.d/debian.sources 2>/dev/null || true)
[ -n "$mirror" ] || mirror=$(awk '/^deb /{print $2; exit}' /etc/apt/sources.list 2>/dev/null || true)
if [ ! -x "$base/bin/bash" ]; then
  command -v debootstrap > /dev/null || { echo "FAIL: debootstrap is not installed (apt-get install debootstrap)"; exit 1; }
  debootstrap --variant=minbase bookworm "$base.tmp" "$mirror" > /dev/null && mv "$base.tmp" "$base"
fi
cp -a "$base/." "$root/"
cp /etc/resolv.conf "$root/etc/resolv.conf"
printf '#!/bin/sh\nexit 101\n' > "$root/usr/sbin/policy-rc.d"; chmod +x "$root/usr/sbin/policy-rc.d"
for m in proc dev dev/pts sys; do mount --bind "/$m" "$root/$m"; mounted+=("$root/$m"); done

(cd "$build" && cpack -G DEB --config "$build/CPackConfig.cmake" -B "$root/root/deb" > "$root/root/cpack.log" 2>&1) ||
  { cat "$root/root/cpack.log"; echo "FAIL: cpack"; exit 1; }
mkdir -p "$root/root/project/kiln-src"
cp -r "$source/tests/cmake_consumer" "$root/root/project/consumer"
cp -r "$source/shaderlib" "$source/variants" "$root/root/project/"
ln -s ../variants "$root/root/project/kiln-src/variants"
# A pack for the reader's stage (kiln is not installed then): built here by the tree's kiln.
"$build/compiler/kiln" build "$source/tests/capi/tiny.pack.json" -o "$root/root/project/pack" --no-cache -q
cat > "$root/root/project/game.c" <<'C'
#include <kiln/kiln_reader.h>
int main(void) {
  kiln_pack* pack;
  kiln_error error;
  if (kiln_pack_open("pack", &pack, &error) != KILN_OK) return 1;
  kiln_pack_close(pack);
  return 0;
}
C
mkdir "$root/root/project/c-project"
cp "$root/root/project/game.c" "$root/root/project/c-project/"
printf 'cmake_minimum_required(VERSION 3.25)\nproject(c_game LANGUAGES C)\nfind_package(kiln REQUIRED)\nadd_executable(game game.c)\ntarget_link_libraries(game PRIVATE kiln::reader)\n' \
  > "$root/root/project/c-project/CMakeLists.txt"
printf '#if QUALITY != 2\n#error QUALITY must be 2\n#endif\nfloat4 F() : SV_Target { return 1.0; }\n' > "$root/root/project/Q.hlsl"

# Each package is installed on a machine that has only what it depends on, and each stage checks what did not come.
chroot "$root" bash -euo pipefail -c "
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -q > /dev/null
  absent() {
    for package in \"\$@\"; do
      if dpkg-query -W -f='\${Status}' \$package 2> /dev/null | grep 'install ok installed' > /dev/null; then
        echo \"FAIL: \$package came with the packages installed so far\"; exit 1
      fi
    done
  }
  apt_install() { apt-get install -y -q --no-install-recommends \"\$@\" > /root/apt.log 2>&1 || { tail -30 /root/apt.log; exit 1; }; }
  cd /root/project
  echo '== the reader for developers, and gcc: a C program links with the C compiler alone'
  apt_install /root/deb/libkiln-reader-dev_*.deb /root/deb/libkiln-reader0_*.deb gcc libc6-dev pkgconf
  absent kiln g++ libvulkan1 libegl1 libx11-6
  gcc -std=c11 game.c \$(pkg-config --cflags --libs kiln-reader) -o game
  ./game
  echo '== the CLI alone: kiln lints with defines, and nothing of Vulkan, EGL or X11 comes'
  apt_install /root/deb/kiln_*.deb
  absent kiln-verify g++ libvulkan1 libegl1 libx11-6
  kiln --version | head -1
  kiln lint Q.hlsl -D QUALITY=2 --werror
  ! kiln lint Q.hlsl -D QUALITY=1 --werror > /dev/null 2>&1
  # SARIF's help links open the installed docs.
  kiln lint Q.hlsl -D QUALITY=2 --format sarif -o q.sarif
  grep -q 'helpUri.: *.file:///usr/share/doc/kiln/lint.md#' q.sarif
  test -f /usr/share/doc/kiln/lint.md
  echo '== CMake: a LANGUAGES C project links kiln::reader'
  apt_install cmake ninja-build
  absent g++
  cmake -S c-project -B c-build -G Ninja > c-configure.log
  cmake --build c-build > c-build.log
  (cd /root/project && c-build/game)
  echo '== kiln-verify, and a C++ consumer project built with kiln_add_shader_pack'
  apt_install /root/deb/kiln-verify_*.deb g++
  kiln-verify --help > /dev/null
  cmake -S consumer -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DKILN_CONSUMER_MODE=find_package \
    -DKILN_SOURCE_DIR=/root/project/kiln-src -DKILN_CONSUMER_SCENES=/root/project/variants/scenes/mobile.json > configure.log
  grep -qxF 'kiln_DIR:PATH=/usr/lib/cmake/kiln' build/CMakeCache.txt
  cmake --build build -j 2 > build.log 2>&1 || { tail -30 build.log; exit 1; }
  build/consumer
  test -f /usr/share/man/man1/kiln.1.gz
"
echo "fresh Debian package test passed"
