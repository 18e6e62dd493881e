/* SPDX-License-Identifier: Apache-2.0 */
/* Development mode for the C reader (docs/reader.md, "On-demand variants"): kiln/development_reader.hpp from C.
 * Linked from kiln::reader_dev (libcurl); a release build does not link it, so a release reader never connects.
 *
 *   kiln_development* dev = NULL;
 *   kiln_development_from_environment(pack, "out/lit.manifest.json", &dev, &error);  // NULL unless
 *                                                                                      // KILN_DEVELOPMENT_ENDPOINT is set
 *   uint32_t variant; int nearest;
 *   if (dev) kiln_development_select_or_nearest(dev, "Forward", names, 2, &variant, &nearest, &error);
 *
 * The endpoint is 127.0.0.1 only; answers are bounded and checked. Not thread-safe against other calls on the same
 * pack, as kiln_pack_poll_update is not. */
#ifndef KILN_READER_DEV_H
#define KILN_READER_DEV_H

#include "kiln/kiln_reader.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct kiln_development kiln_development; /* development mode for one pack (opaque) */

/* For `pack`, opened from `manifest_path` (which says where kiln watch's endpoint file is). `endpoint`:
 * "127.0.0.1:PORT", or NULL for the endpoint file beside the manifest. Connects to nothing yet. IO for an endpoint
 * that is not loopback. kiln_development_close it before kiln_pack_close. */
kiln_result kiln_development_open(kiln_pack* pack, const char* manifest_path, const char* endpoint,
                                  kiln_development** development, kiln_error* error);
/* kiln_development_open when KILN_DEVELOPMENT_ENDPOINT is set ("127.0.0.1:PORT", or "auto": the endpoint file);
 * else OK with *development NULL and nothing opened. */
kiln_result kiln_development_from_environment(kiln_pack* pack, const char* manifest_path, kiln_development** development,
                                              kiln_error* error);
void kiln_development_close(kiln_development* development); /* NULL is allowed; waits for a request under way */

/* kiln_pack_poll_update, then what the game selected since the last report sent to kiln watch in the background
 * (at most every 500 ms, and only keyword sets not reported yet), so that watch builds those first in its next
 * round. Call it where the game would call kiln_pack_poll_update. It starts usage recording into a file of its own
 * at kiln_development_open (removed at kiln_development_close): a game that records usage itself, with
 * kiln_pack_record_usage, has its selections reported from the C++ API (DevelopmentReader::Options::selected_log). */
kiln_result kiln_development_poll_update(kiln_development* development, kiln_pack_update* update, kiln_error* error);

/* kiln_select_by_names; when the pack lacks the variant (STRIPPED), asks kiln watch for it, waits up to
 * `timeout_ms`, switches the pack with kiln_pack_poll_update (its changes are not handed back: select again what
 * you cache) and selects again. */
kiln_result kiln_development_select_or_wait(kiln_development* development, const char* pass, const char* const* keywords,
                                            size_t count, uint32_t timeout_ms, uint32_t* variant, kiln_error* error);
/* kiln_select_by_names; when the pack lacks the variant, the nearest variant of the pass now (*nearest = 1) and the
 * request sent in the background: a later kiln_pack_poll_update lists the real one as KILN_VARIANT_ADDED. */
kiln_result kiln_development_select_or_nearest(kiln_development* development, const char* pass, const char* const* keywords,
                                               size_t count, uint32_t* variant, int* nearest, kiln_error* error);

#ifdef __cplusplus
}
#endif

#endif /* KILN_READER_DEV_H */
