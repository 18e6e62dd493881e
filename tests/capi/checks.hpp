// SPDX-License-Identifier: Apache-2.0
// The checks of the reader's C++ test programs (tests/capi/*.cpp): plain programs, no GoogleTest, so that one can be
// built with -fno-exceptions -fno-rtti. A failed CHECK is printed with its line and counted; main returns 1 if any.
#pragma once

#include <cstdio>

namespace kiln::checks {

inline int failures = 0;

inline void check(bool ok, int line, const char* what) {
  if (ok) return;
  std::fprintf(stderr, "line %d: check failed: %s\n", line, what);
  ++failures;
}

// What main returns: 0, or 1 after saying how many checks failed.
inline int result() {
  if (failures) std::fprintf(stderr, "%d check(s) failed\n", failures);
  return failures ? 1 : 0;
}

}  // namespace kiln::checks

#define CHECK(condition) ::kiln::checks::check((condition), __LINE__, #condition)
