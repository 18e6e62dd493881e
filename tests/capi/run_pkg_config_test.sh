#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# cmake.pkg_config.CProgramBuildsAgainstTheInstalledReader: the installed reader, used without CMake.
#   `cmake --install` installs kiln-reader.pc and kiln_reader.h; no installed header includes nlohmann-json (the
#   compiler's include trace, -H, is searched, so an indirect include counts); kiln_reader.h is C99; a C program
#   built with `cc main.c $(pkg-config --cflags --libs kiln-reader)` alone (PKG_CONFIG_PATH at the prefix; the
#   shared reader, no C++ runtime named) opens a pack the installed kiln built and selects a variant.
# usage: run_pkg_config_test.sh <kiln source dir> <kiln build dir>
set -euo pipefail
source=$1 build=$2
work=$(mktemp -d "${TMPDIR:-/tmp}/kiln-pkg-config-XXXXXX")
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
cmake --install "$build" --prefix "$work/prefix" > /dev/null

echo "== kiln-reader.pc and the headers are installed"
pc=$(find "$work/prefix" -name kiln-reader.pc)
[ -n "$pc" ] || fail "no kiln-reader.pc under the prefix"
for header in kiln_reader.h pack_reader.hpp manifest.hpp pack_format.hpp stage_target.hpp folded_keywords.hpp coverage_map.hpp; do
  [ -f "$work/prefix/include/kiln/$header" ] || fail "include/kiln/$header not installed"
done
[ ! -e "$work/prefix/include/kiln/manifest_json.hpp" ] || fail "manifest_json.hpp (nlohmann-json) is installed"

echo "== no installed header includes nlohmann-json"
for header in "$work/prefix/include/kiln/"*; do
  printf '#include "%s"\n' "$header" > "$work/header.cpp"
  c++ -std=c++20 -fsyntax-only -H -I"$work/prefix/include" "$work/header.cpp" 2> "$work/trace.txt" ||
    { cat "$work/trace.txt"; fail "$(basename "$header") does not compile on its own"; }
  if grep -q nlohmann "$work/trace.txt"; then grep nlohmann "$work/trace.txt" | head -3; fail "$(basename "$header") includes nlohmann-json"; fi
done
printf '#include <kiln/kiln_reader.h>\nint main(void) { return kiln_pass_count(0) != 0; }\n' > "$work/c99.c"
cc -std=c99 -pedantic -Wall -Wextra -Werror -fsyntax-only -I"$work/prefix/include" "$work/c99.c" || fail "kiln_reader.h is not C99"

echo "== a C program built with pkg-config only"
"$work/prefix/bin/kiln" build "$source/tests/capi/tiny.pack.json" -o "$work/pack" --no-cache -q
cat > "$work/main.c" <<'C'
#include <stdio.h>
#include <kiln/kiln_reader.h>
int main(int argc, char** argv) {
  kiln_error error;
  kiln_pack* pack;
  kiln_pass pass;
  kiln_keyword low;
  uint32_t variant;
  kiln_code code;
  if (argc != 2 || kiln_pack_open(argv[1], &pack, &error) != KILN_OK ||
      kiln_pass_find(pack, "Main", &pass, &error) != KILN_OK || kiln_keyword_find(pack, "QUALITY_LOW", &low, &error) != KILN_OK ||
      kiln_select(pack, pass, &low, 1, 0, &variant, &error) != KILN_OK ||
      kiln_variant_code(pack, pass, variant, KILN_STAGE_VERTEX, KILN_TARGET_SPIRV, &code, &error) != KILN_OK) {
    fprintf(stderr, "%s: %s\n", error.file, error.message);
    return 1;
  }
  printf("%s %s: variant %u, %zu bytes of vertex SPIR-V\n", kiln_pack_name(pack), kiln_pass_name(pack, pass), variant, code.size);
  kiln_pack_close(pack);
  return 0;
}
C
export PKG_CONFIG_PATH="$(dirname "$pc")"
flags=$(pkg-config --cflags --libs kiln-reader) || fail "pkg-config --cflags --libs kiln-reader"
echo "pkg-config: $flags"
! grep -q "stdc++" <<< "$flags" || fail "pkg-config names the C++ runtime: the shared reader brings it"
cc -std=c11 -Wall -Wextra -pedantic -Werror -o "$work/consumer" "$work/main.c" $flags || fail "the C consumer does not build"
# The shared reader, found where it was installed (a system prefix needs no LD_LIBRARY_PATH).
LD_LIBRARY_PATH="$work/prefix/lib" "$work/consumer" "$work/pack" > "$work/out.txt" || { cat "$work/out.txt"; fail "the C consumer failed"; }
readelf -d "$work/consumer" | grep "NEEDED.*\[libkiln_reader.so.0\]" > /dev/null || fail "the consumer does not link libkiln_reader.so.0"
cat "$work/out.txt"
grep -qE '^tiny Main: variant [0-9]+, [1-9][0-9]* bytes of vertex SPIR-V$' "$work/out.txt" || fail "unexpected output"
echo "ok"
