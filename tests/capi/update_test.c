/* SPDX-License-Identifier: Apache-2.0 */
/* unit.capi.FromC11APollSwitchesToARebuiltPackAndRefusesADamagedOne: live updates through the C API (kiln_reader.h,
 * docs/reader.md "Live updates"), in C11. A copy of the tiny pack is opened; the pack rebuilt after two edits
 * (tiny-edited.pack.json: the Depth pass's fragment shader changed, the constraint that stripped FOG with TINT
 * dropped) is swapped in as a build writes it (the archive, then the manifest, each renamed into place); one poll
 * switches and lists every Depth variant as changed and no Main variant as changed (only added or moved); code
 * handed out before the switch is still readable; a damaged manifest is refused with its error, once, and the pack
 * keeps serving.
 * usage: update_test <tiny pack dir> <tiny-edited pack dir> <scratch dir> */
#define _POSIX_C_SOURCE 200809L
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "checks.h"
#include "kiln/kiln_reader.h"

/* The whole file, NUL-terminated (*size without the NUL); NULL when it cannot be read. */
static char* read_file(const char* path, size_t* size) {
  FILE* in = fopen(path, "rb");
  char* bytes = NULL;
  long length;
  if (!in) return NULL;
  if (fseek(in, 0, SEEK_END) == 0 && (length = ftell(in)) >= 0 && fseek(in, 0, SEEK_SET) == 0 &&
      (bytes = malloc((size_t)length + 1)) != NULL) {
    *size = fread(bytes, 1, (size_t)length, in);
    bytes[*size] = '\0';
  }
  fclose(in);
  return bytes;
}

/* `bytes` into `path` as kiln writes a pack's files: a temporary file beside it, renamed over it. */
static int write_file(const char* path, const char* bytes, size_t size) {
  char temporary[1024];
  FILE* out;
  snprintf(temporary, sizeof temporary, "%s.tmp", path);
  out = fopen(temporary, "wb");
  if (!out) return 0;
  if (fwrite(bytes, 1, size, out) != size) size = 0;
  if (fclose(out) != 0 || size == 0) return 0;
  return rename(temporary, path) == 0;
}

/* The archive file name that `manifest` names ("tiny.<xxh3>.kpack"), into `name`. */
static int archive_named(const char* manifest, char* name, size_t capacity) {
  const char* at = strstr(manifest, "\"archive\"");
  const char* end;
  if (!at || !(at = strstr(at, "\"file\": \""))) return 0;
  at += strlen("\"file\": \"");
  end = strchr(at, '"');
  if (!end || (size_t)(end - at) >= capacity) return 0;
  memcpy(name, at, (size_t)(end - at));
  name[end - at] = '\0';
  return 1;
}

/* Copies pack `from` (its manifest and the archive it names) into directory `to`: the archive first. */
static int install_pack(const char* from, const char* to) {
  char path[1024], archive[256];
  size_t manifest_size = 0, archive_size = 0;
  char *manifest, *bytes;
  int ok;
  snprintf(path, sizeof path, "%s/tiny.manifest.json", from);
  manifest = read_file(path, &manifest_size);
  if (!manifest || !archive_named(manifest, archive, sizeof archive)) return 0;
  snprintf(path, sizeof path, "%s/%s", from, archive);
  bytes = read_file(path, &archive_size);
  snprintf(path, sizeof path, "%s/%s", to, archive);
  ok = bytes && write_file(path, bytes, archive_size);
  snprintf(path, sizeof path, "%s/tiny.manifest.json", to);
  ok = ok && write_file(path, manifest, manifest_size);
  free(bytes);
  free(manifest);
  return ok;
}

static int has_keyword(const kiln_variant_change* change, const char* keyword) {
  uint32_t k;
  for (k = 0; k < change->keyword_count; ++k)
    if (strcmp(change->keywords[k], keyword) == 0) return 1;
  return 0;
}

int main(int argc, char** argv) {
  char live[1024], manifest_path[1100];
  char* before_copy = NULL;
  kiln_error error;
  kiln_pack* pack = NULL;
  kiln_pack_update update;
  kiln_pass main_pass = 0, depth = 0;
  kiln_keyword low = 0;
  uint32_t variant = 0, depth_variants = 0;
  kiln_code before, code;
  size_t i, depth_changed = 0, main_added = 0, main_changed = 0, size = 0;
  char* manifest;
  if (argc != 4) return 2;
  snprintf(live, sizeof live, "%s/live", argv[3]);
  snprintf(manifest_path, sizeof manifest_path, "%s/tiny.manifest.json", live);
  {
    char command[2200];
    snprintf(command, sizeof command, "rm -rf '%s' && mkdir -p '%s'", live, live);
    if (system(command) != 0) return 2;
  }
  CHECK(install_pack(argv[1], live));
  CHECK(kiln_pack_open(live, &pack, &error) == KILN_OK);
  if (!pack) return 1;
  CHECK(kiln_pass_find(pack, "Main", &main_pass, &error) == KILN_OK);
  CHECK(kiln_pass_find(pack, "Depth", &depth, &error) == KILN_OK);
  CHECK(kiln_keyword_find(pack, "QUALITY_LOW", &low, &error) == KILN_OK);
  depth_variants = kiln_variant_count(pack, depth);
  CHECK(kiln_select(pack, depth, NULL, 0, 0, &variant, &error) == KILN_OK);
  CHECK(kiln_variant_code(pack, depth, variant, KILN_STAGE_FRAGMENT, KILN_TARGET_SPIRV, &before, &error) == KILN_OK);
  CHECK(before.size > 0 && (before_copy = malloc(before.size)) != NULL);
  if (!before_copy) return 1;
  memcpy(before_copy, before.bytes, before.size);

  /* Nothing new yet. */
  CHECK(kiln_pack_poll_update(pack, &update, &error) == KILN_OK);
  CHECK(update.switched == 0 && update.change_count == 0 && update.version == 1);

  /* The rebuilt pack, swapped in. */
  CHECK(install_pack(argv[2], live));
  CHECK(kiln_pack_poll_update(pack, &update, &error) == KILN_OK);
  CHECK(update.switched == 1);
  CHECK(update.version == 2);
  CHECK(update.ids_changed == 0);
  CHECK(update.archive != NULL && strncmp(update.archive, "tiny.", 5) == 0);
  for (i = 0; i < update.change_count; ++i) {
    const kiln_variant_change* change = &update.changes[i];
    if (strcmp(change->pass, "Depth") == 0) {
      CHECK(change->kind == KILN_VARIANT_CHANGED);
      CHECK(change->old_pass == depth && change->new_pass == depth);
      CHECK(change->old_variant == change->new_variant);
      ++depth_changed;
    } else {
      CHECK(strcmp(change->pass, "Main") == 0);
      CHECK(change->kind == KILN_VARIANT_ADDED || change->kind == KILN_VARIANT_MOVED);
      if (change->kind == KILN_VARIANT_ADDED) {
        CHECK(has_keyword(change, "FOG") && has_keyword(change, "TINT"));
        CHECK(change->old_variant == KILN_NO_INDEX && change->new_variant < kiln_variant_count(pack, main_pass));
        ++main_added;
      }
      if (change->kind == KILN_VARIANT_CHANGED) ++main_changed;
    }
  }
  CHECK(depth_changed == depth_variants);
  CHECK(main_added > 0);
  CHECK(main_changed == 0);
  CHECK(memcmp(before.bytes, before_copy, before.size) == 0); /* handed out before the switch: still readable */
  CHECK(kiln_select(pack, depth, NULL, 0, 0, &variant, &error) == KILN_OK);
  CHECK(kiln_variant_code(pack, depth, variant, KILN_STAGE_FRAGMENT, KILN_TARGET_SPIRV, &code, &error) == KILN_OK);
  CHECK(code.size != before.size || memcmp(code.bytes, before_copy, code.size) != 0); /* the edit */
  {
    kiln_keyword wanted[3];
    CHECK(kiln_keyword_find(pack, "FOG", &wanted[0], &error) == KILN_OK);
    CHECK(kiln_keyword_find(pack, "TINT", &wanted[1], &error) == KILN_OK);
    wanted[2] = low;
    CHECK(kiln_select(pack, main_pass, wanted, 3, 0, &variant, &error) == KILN_OK); /* stripped before the switch */
  }

  /* A damaged manifest: refused with its error, once; the pack keeps serving. */
  manifest = read_file(manifest_path, &size);
  CHECK(manifest != NULL && size > 100);
  if (manifest) {
    manifest[size / 2] = (char)(manifest[size / 2] ^ 1);
    CHECK(write_file(manifest_path, manifest, size));
    free(manifest);
  }
  CHECK(kiln_pack_poll_update(pack, &update, &error) == KILN_ERROR_CHECKSUM);
  CHECK(strstr(error.file, "tiny.manifest.json") != NULL);
  CHECK(update.switched == 0 && update.change_count == 0);
  CHECK(kiln_select(pack, depth, NULL, 0, 0, &variant, &error) == KILN_OK);
  CHECK(kiln_pack_poll_update(pack, &update, &error) == KILN_OK);
  CHECK(update.switched == 0);
  kiln_pack_close(pack);
  free(before_copy);
  if (failures) fprintf(stderr, "%d check(s) failed\n", failures);
  return failures ? 1 : 0;
}
