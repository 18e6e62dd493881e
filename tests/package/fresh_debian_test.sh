#!/usr/bin/env bash
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
cp "$source/tests/capi/tiny.pack.json" "$source/tests/capi/Tiny.hlsl" "$root/root/project/"

chroot "$root" bash -euo pipefail -c "
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -q > /dev/null
  cd /root/deb
  # kiln alone, as a CI runner that only lints installs it: the reader and the CLI, with gcc and nothing else; kiln's
  # own libraries come from the packages' Depends only, and nothing of Vulkan, EGL or X11 comes with them.
  apt-get install -y -q --no-install-recommends ./kiln_*.deb ./libkiln-reader0_*.deb ./libkiln-reader-dev_*.deb gcc libc6-dev \
    > /root/apt.log 2>&1 || { tail -30 /root/apt.log; exit 1; }
  kiln --version | head -1
  for absent in libvulkan1 libegl1 libx11-6 g++; do
    if dpkg-query -W -f='\${Status}' \$absent 2> /dev/null | grep -q 'install ok installed'; then echo \"FAIL: kiln brought \$absent\"; exit 1; fi
  done
  # A C program, linked by gcc alone with pkg-config's flags (no C++ compiler on the machine).
  cd /root/project
  kiln build tiny.pack.json -o pack --no-cache -q
  printf '#include <kiln/kiln_reader.h>\\nint main(void) { kiln_pack* p; kiln_error e; int ok = kiln_pack_open(\"pack\", &p, &e) == KILN_OK; if (ok) kiln_pack_close(p); return !ok; }\\n' > game.c
  gcc -std=c11 game.c \$(pkg-config --cflags --libs kiln-reader) -o game
  ./game
  # Then kiln-verify and what builds a C++ consumer project.
  apt-get install -y -q --no-install-recommends /root/deb/kiln-verify_*.deb cmake ninja-build g++ > /root/apt.log 2>&1 ||
    { tail -30 /root/apt.log; exit 1; }
  kiln-verify --help > /dev/null
  cmake -S consumer -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DKILN_CONSUMER_MODE=find_package \
    -DKILN_SOURCE_DIR=/root/project/kiln-src -DKILN_CONSUMER_SCENES=/root/project/variants/scenes/mobile.json > configure.log
  grep -qxF 'kiln_DIR:PATH=/usr/lib/cmake/kiln' build/CMakeCache.txt
  cmake --build build -j 2 > build.log 2>&1 || { tail -30 build.log; exit 1; }
  build/consumer
  test -f /usr/share/man/man1/kiln.1.gz
"
echo "fresh Debian package test passed"
