/* SPDX-License-Identifier: Apache-2.0 */
/* The checks of the reader's C test programs (the .c files here; checks.hpp is the C++ programs'): a failed CHECK is
 * printed with its file and line and counted in `failures`, which main returns. One definition per program: include
 * it from the program's one source file. */
#ifndef KILN_TESTS_CAPI_CHECKS_H
#define KILN_TESTS_CAPI_CHECKS_H

#include <stdio.h>

static int failures = 0;

#define CHECK(condition)                                                              \
  do {                                                                                \
    if (!(condition)) {                                                               \
      fprintf(stderr, "%s:%d: check failed: %s\n", __FILE__, __LINE__, #condition); \
      ++failures;                                                                     \
    }                                                                                 \
  } while (0)

#endif
