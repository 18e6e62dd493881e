/* SPDX-License-Identifier: Apache-2.0 */
/* kiln_reader_dev.h from C11 (unit.capi.FromC11DevelopmentModeIsOptInAndLoopbackOnly): the header is C, development
 * mode opens only when asked (the variable unset: nothing), and only for a loopback endpoint. No server runs here:
 * opening connects to nothing (diag.DevelopmentEndpoint.* serves real requests). */
#define _POSIX_C_SOURCE 200809L
#include <stdlib.h>

#include "checks.h"
#include "kiln/kiln_reader_dev.h"

int main(int argc, char** argv) {
  kiln_pack* pack = NULL;
  kiln_development* development = NULL;
  kiln_error error;
  if (argc != 3) {
    fprintf(stderr, "usage: %s PACK_DIR MANIFEST\n", argv[0]);
    return 2;
  }
  CHECK(kiln_pack_open(argv[1], &pack, &error) == KILN_OK);
  if (!pack) return 1;

  unsetenv("KILN_DEVELOPMENT_ENDPOINT");
  development = (kiln_development*)&error; /* set to NULL by the call */
  CHECK(kiln_development_from_environment(pack, argv[2], &development, &error) == KILN_OK);
  CHECK(development == NULL);

  setenv("KILN_DEVELOPMENT_ENDPOINT", "10.0.0.1:80", 1);
  CHECK(kiln_development_from_environment(pack, argv[2], &development, &error) == KILN_ERROR_IO);
  CHECK(development == NULL);
  setenv("KILN_DEVELOPMENT_ENDPOINT", "0.0.0.0:80", 1);
  CHECK(kiln_development_from_environment(pack, argv[2], &development, &error) == KILN_ERROR_IO);
  unsetenv("KILN_DEVELOPMENT_ENDPOINT");

  CHECK(kiln_development_open(NULL, argv[2], NULL, &development, &error) == KILN_ERROR_INVALID_ARGUMENT);
  CHECK(kiln_development_open(pack, argv[2], "127.0.0.1:1", &development, &error) == KILN_OK);
  CHECK(development != NULL);
  {
    uint32_t variant = 0;
    int nearest = 0;
    CHECK(kiln_development_select_or_nearest(development, NULL, NULL, 0, &variant, &nearest, &error) ==
          KILN_ERROR_INVALID_ARGUMENT);
    CHECK(kiln_development_select_or_wait(development, "NoSuchPass", NULL, 0, 1000, &variant, &error) ==
          KILN_ERROR_UNKNOWN_PASS); /* an error select gives is not a request */
  }
  kiln_development_close(development);
  kiln_development_close(NULL);
  kiln_pack_close(pack);
  return failures;
}
