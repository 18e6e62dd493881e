// SPDX-License-Identifier: Apache-2.0
// unit.capi.FromCxxWithoutExceptionsSelectionByIdsAllocatesNothing: kiln_reader.h from C++ built with
// -fno-exceptions -fno-rtti, as games often are. It compiles, links and selects; a failing call returns its code instead of aborting; and a successful selection by
// ids allocates nothing (this executable counts every operator new, the reader's included, since the reader is
// linked in): the evidence that kiln_select does no string work per call, without timing anything.
// usage: capi_no_exceptions_test <pack dir>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <new>

#include "kiln/kiln_reader.h"

namespace {
unsigned long allocations = 0;
}

void* operator new(std::size_t size) {
  ++allocations;
  if (void* p = std::malloc(size ? size : 1)) return p;
  std::abort();  // -fno-exceptions: no bad_alloc to throw
}
void* operator new[](std::size_t size) { return operator new(size); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }

int main(int argc, char** argv) {
  if (argc != 2) return 2;
  kiln_error error;
  kiln_pack* pack = nullptr;
  if (kiln_pack_open(argv[1], &pack, &error) != KILN_OK) {
    std::fprintf(stderr, "%s: %s\n", error.file, error.message);
    return 1;
  }
  int failures = 0;
  auto check = [&](bool ok, const char* what) {
    if (!ok) {
      std::fprintf(stderr, "check failed: %s (%s)\n", what, error.message);
      ++failures;
    }
  };
  kiln_pass main_pass = 0;
  kiln_keyword low = 0, high = 0, tint = 0;
  check(kiln_pass_find(pack, "Main", &main_pass, &error) == KILN_OK, "pass Main");
  check(kiln_keyword_find(pack, "QUALITY_LOW", &low, &error) == KILN_OK, "keyword QUALITY_LOW");
  check(kiln_keyword_find(pack, "QUALITY_HIGH", &high, &error) == KILN_OK, "keyword QUALITY_HIGH");
  check(kiln_keyword_find(pack, "TINT", &tint, &error) == KILN_OK, "keyword TINT");

  const kiln_keyword wanted[] = {tint, low};
  uint32_t variant = 0, expected = 0;
  const char* names[] = {"QUALITY_LOW", "TINT"};
  check(kiln_select_by_names(pack, "Main", names, 2, 0, &expected, &error) == KILN_OK, "select by names");
  const unsigned long before = allocations;
  for (int i = 0; i < 1000; ++i) {
    variant = 12345;
    if (kiln_select(pack, main_pass, wanted, 2, 0, &variant, &error) != KILN_OK || variant != expected) {
      check(false, "select by ids");
      break;
    }
  }
  const unsigned long during = allocations - before;
  if (during != 0) {
    std::fprintf(stderr, "1000 selections by ids made %lu allocations; expected none\n", during);
    ++failures;
  }

  // An error is a code and a message, not an abort.
  const kiln_keyword conflicting[] = {low, high};
  check(kiln_select(pack, main_pass, conflicting, 2, 0, &variant, &error) == KILN_ERROR_CONFLICTING_KEYWORDS,
        "conflicting keywords are an error code");
  check(std::strstr(error.message, "a group takes at most one keyword") != nullptr, "its message");

  kiln_code code{};
  check(kiln_variant_code(pack, main_pass, expected, KILN_STAGE_FRAGMENT, KILN_TARGET_SPIRV, &code, &error) == KILN_OK &&
            code.size > 0,
        "fragment SPIR-V");
  kiln_pack_close(pack);
  if (failures == 0) std::printf("ok: 1000 selections by ids, %lu allocations\n", during);
  return failures != 0;
}
