/* SPDX-License-Identifier: Apache-2.0 */
/* unit.capi.FromC11EveryErrorSelectionCodeAndReflection: kiln_reader.h from C11 (-Wall -Wextra -pedantic
 * -Werror), on the pack tests/capi/tiny.pack.json builds (unit.capi.setup). usage: capi_test <pack dir> <scratch dir>
 * Passes: Main (groups [_ FOG], [QUALITY_LOW QUALITY_HIGH], fragment [_ TINT]; TINT excludes FOG) and Depth
 * ([_ ALPHA_CLIP]). With a third argument, the pack tests/capi/texels.pack.json builds (unit.capi.setup_texels): its
 * texel buffers and input attachment, by their kinds. Every check prints what it compared on failure; the exit code
 * is the number of failures. */
#define _POSIX_C_SOURCE 200809L
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "checks.h"
#include "kiln/kiln_reader.h"

static void check_error(int line, kiln_result got, const kiln_error* error, kiln_result code, const char* message) {
  if (got != code || error->code != code) {
    fprintf(stderr, "%s:%d: expected %s, got %s (%s)\n", __FILE__, line, kiln_result_name(code), kiln_result_name(got),
            error->message);
    ++failures;
  } else if (message && strcmp(error->message, message) != 0) {
    fprintf(stderr, "%s:%d: expected message\n  %s\ngot\n  %s\n", __FILE__, line, message, error->message);
    ++failures;
  }
}
#define CHECK_ERROR(got, error, code, message) check_error(__LINE__, got, error, code, message)

static kiln_keyword keyword(const kiln_pack* pack, const char* name) {
  kiln_keyword id = UINT32_MAX;
  kiln_error error;
  if (kiln_keyword_find(pack, name, &id, &error) != KILN_OK) {
    fprintf(stderr, "keyword %s: %s\n", name, error.message);
    ++failures;
  }
  return id;
}

static int copy_file(const char* from, const char* to, long truncate_at, long flip_at) {
  FILE* in = fopen(from, "rb");
  FILE* out = fopen(to, "wb");
  long at = 0;
  int c;
  if (!in || !out) return 0;
  while ((c = fgetc(in)) != EOF && (truncate_at < 0 || at < truncate_at)) {
    fputc(at == flip_at ? (c == 'a' ? 'b' : 'a') : c, out);
    ++at;
  }
  fclose(in);
  fclose(out);
  return 1;
}

/* Opening: a missing file, a manifest changed after the build, a manifest cut short. */
static void test_open_failures(const char* pack_dir, const char* scratch) {
  kiln_error error;
  kiln_pack* pack = (kiln_pack*)1;
  char path[1024], from[1024];
  snprintf(path, sizeof path, "%s/no-such.manifest.json", scratch);
  CHECK_ERROR(kiln_pack_open(path, &pack, &error), &error, KILN_ERROR_IO, "no such file or directory");
  CHECK(pack == NULL);
  CHECK(strcmp(error.file, path) == 0);
  CHECK_ERROR(kiln_pack_open(NULL, &pack, &error), &error, KILN_ERROR_INVALID_ARGUMENT, NULL);
  CHECK(kiln_pack_open(path, &pack, NULL) == KILN_ERROR_IO); /* no kiln_error: still a code */

  /* The archive is found beside the manifest by the name it records; copy both, then damage the manifest. */
  {
    kiln_pack* good = NULL;
    CHECK(kiln_pack_open(pack_dir, &good, &error) == KILN_OK);
    kiln_pack_close(good);
  }
  snprintf(from, sizeof from, "%s/tiny.manifest.json", pack_dir);
  snprintf(path, sizeof path, "%s/tiny.manifest.json", scratch);
  {
    /* The archive: the one *.kpack file in the pack directory; its name is in the manifest, copy it too. */
    char command[4096];
    snprintf(command, sizeof command, "cp %s/*.kpack %s/", pack_dir, scratch);
    CHECK(system(command) == 0);
  }
  /* A byte inside a string value (the first entry point, "Vert"), still valid JSON: the manifest's own checksum fails. */
  {
    FILE* f = fopen(from, "rb");
    char head[1024] = {0};
    const char* name;
    CHECK(f && fread(head, 1, sizeof head - 1, f) > 0);
    if (f) fclose(f);
    name = strstr(head, "\"Vert\"");
    CHECK(name != NULL);
    CHECK(copy_file(from, path, -1, name ? (long)(name - head) + 1 : 0));
    CHECK_ERROR(kiln_pack_open(path, &pack, &error), &error, KILN_ERROR_CHECKSUM, NULL);
    CHECK(strstr(error.message, "checksum") != NULL);
    CHECK(strcmp(error.file, path) == 0);
    CHECK(pack == NULL);
  }
  /* Cut short: the checksum is looked for before the text is parsed, and is not there. */
  CHECK(copy_file(from, path, 100, -1));
  CHECK_ERROR(kiln_pack_open(path, &pack, &error), &error, KILN_ERROR_FORMAT, NULL);
  CHECK(strcmp(error.file, path) == 0);
  CHECK(strstr(error.message, "no checksum") != NULL);
  CHECK(pack == NULL);
}

/* Each selection error: its code and the C++ reader's message, by names and by ids alike. */
static void test_selection_errors(const kiln_pack* pack) {
  kiln_error error;
  uint32_t variant = 77;
  kiln_pass main_pass;
  const char* conflicting[] = {"QUALITY_LOW", "QUALITY_HIGH"};
  const char* missing[] = {"FOG"};
  const char* stripped[] = {"FOG", "TINT", "QUALITY_LOW"};
  const char* foreign[] = {"QUALITY_LOW", "ALPHA_CLIP"};
  kiln_keyword ids[3];
  const char* conflict_message =
      "pass 'Main': keywords of one group requested together, including 'QUALITY_LOW'; a group takes at most one keyword";
  const char* missing_message = "pass 'Main' needs one of: QUALITY_LOW QUALITY_HIGH";
  const char* stripped_message =
      "pass 'Main' has no variant [FOG QUALITY_LOW TINT]: it was stripped from pack 'tiny' (constraints, scene profiles or "
      "budget); nearest variants in the pack: [FOG QUALITY_LOW] [QUALITY_LOW TINT] [QUALITY_LOW]";
  const char* unknown_message = "pass 'Main' does not declare keyword 'ALPHA_CLIP'";

  CHECK(kiln_pass_find(pack, "Main", &main_pass, &error) == KILN_OK);
  CHECK_ERROR(kiln_pass_find(pack, "Nope", &main_pass, &error), &error, KILN_ERROR_UNKNOWN_PASS, "pack 'tiny' has no pass 'Nope'");
  CHECK_ERROR(kiln_select_by_names(pack, "Nope", NULL, 0, 0, &variant, &error), &error, KILN_ERROR_UNKNOWN_PASS,
              "pack 'tiny' has no pass 'Nope'");
  CHECK_ERROR(kiln_keyword_find(pack, "NOT_A_KEYWORD", &ids[0], &error), &error, KILN_ERROR_UNKNOWN_KEYWORD,
              "pack 'tiny' has no pass that declares keyword 'NOT_A_KEYWORD'");

  CHECK_ERROR(kiln_select_by_names(pack, "Main", conflicting, 2, 0, &variant, &error), &error,
              KILN_ERROR_CONFLICTING_KEYWORDS, conflict_message);
  ids[0] = keyword(pack, "QUALITY_LOW");
  ids[1] = keyword(pack, "QUALITY_HIGH");
  CHECK_ERROR(kiln_select(pack, main_pass, ids, 2, 0, &variant, &error), &error, KILN_ERROR_CONFLICTING_KEYWORDS,
              conflict_message);

  CHECK_ERROR(kiln_select_by_names(pack, "Main", missing, 1, 0, &variant, &error), &error, KILN_ERROR_MISSING_KEYWORD,
              missing_message);
  ids[0] = keyword(pack, "FOG");
  CHECK_ERROR(kiln_select(pack, main_pass, ids, 1, 0, &variant, &error), &error, KILN_ERROR_MISSING_KEYWORD, missing_message);

  CHECK_ERROR(kiln_select_by_names(pack, "Main", stripped, 3, 0, &variant, &error), &error, KILN_ERROR_STRIPPED,
              stripped_message);
  ids[0] = keyword(pack, "FOG");
  ids[1] = keyword(pack, "TINT");
  ids[2] = keyword(pack, "QUALITY_LOW");
  CHECK_ERROR(kiln_select(pack, main_pass, ids, 3, 0, &variant, &error), &error, KILN_ERROR_STRIPPED, stripped_message);

  /* A keyword of another pass: ignored, unless strict. */
  CHECK(kiln_select_by_names(pack, "Main", foreign, 2, 0, &variant, &error) == KILN_OK);
  CHECK_ERROR(kiln_select_by_names(pack, "Main", foreign, 2, 1, &variant, &error), &error, KILN_ERROR_UNKNOWN_KEYWORD,
              unknown_message);
  ids[0] = keyword(pack, "QUALITY_LOW");
  ids[1] = keyword(pack, "ALPHA_CLIP");
  CHECK(kiln_select(pack, main_pass, ids, 2, 0, &variant, &error) == KILN_OK);
  CHECK_ERROR(kiln_select(pack, main_pass, ids, 2, 1, &variant, &error), &error, KILN_ERROR_UNKNOWN_KEYWORD, unknown_message);

  /* Ids out of range are the caller's mistake, not a pack error. */
  ids[0] = kiln_keyword_count(pack);
  CHECK_ERROR(kiln_select(pack, main_pass, ids, 1, 0, &variant, &error), &error, KILN_ERROR_INVALID_ARGUMENT, NULL);
  CHECK_ERROR(kiln_select(pack, kiln_pass_count(pack), NULL, 0, 0, &variant, &error), &error, KILN_ERROR_INVALID_ARGUMENT, NULL);
  CHECK(kiln_select(pack, main_pass, ids, 1, 0, &variant, NULL) == KILN_ERROR_INVALID_ARGUMENT);
}

/* Every variant of every pass is selected by its own keywords, by names and by ids, strict or not, with a
 * keyword of another pass added (ignored) and with its keywords repeated (harmless). */
static void test_selection_by_ids_equals_by_names(const kiln_pack* pack) {
  kiln_error error;
  kiln_pass pass;
  uint32_t v, k;
  int checked = 0;
  for (pass = 0; pass < kiln_pass_count(pack); ++pass) {
    for (v = 0; v < kiln_variant_count(pack, pass); ++v) {
      const char* names[8];
      kiln_keyword ids[16];
      uint32_t count = kiln_variant_keyword_count(pack, pass, v), by_names = 999, by_ids = 999, strict_ids = 999, doubled = 999;
      CHECK(count < 8);
      for (k = 0; k < count && k < 8; ++k) {
        names[k] = kiln_variant_keyword(pack, pass, v, k);
        ids[k] = keyword(pack, names[k]);
        ids[count + k] = ids[k];
      }
      CHECK(kiln_select_by_names(pack, kiln_pass_name(pack, pass), names, count, 1, &by_names, &error) == KILN_OK);
      CHECK(kiln_select(pack, pass, ids, count, 1, &strict_ids, &error) == KILN_OK);
      CHECK(kiln_select(pack, pass, ids, 2 * count, 0, &doubled, &error) == KILN_OK);
      ids[count] = keyword(pack, pass == 0 ? "ALPHA_CLIP" : "FOG"); /* the other pass's */
      CHECK(kiln_select(pack, pass, ids, count + 1, 0, &by_ids, &error) == KILN_OK);
      if (by_names != v || by_ids != v || strict_ids != v || doubled != v) {
        fprintf(stderr, "pass %u variant %u: by names %u, by ids %u, strict %u, doubled %u\n", pass, v, by_names, by_ids,
                strict_ids, doubled);
        ++failures;
      }
      ++checked;
    }
  }
  CHECK(checked == 8); /* Main: 6 variants (8 combinations less 2 stripped), Depth: 2 */
}

/* Code and entry points of the variant [QUALITY_LOW TINT]; reflection enough for a Vulkan pipeline layout, and
 * the GL and MSL bindings. */
static void test_variant_contents(const kiln_pack* pack) {
  kiln_error error;
  kiln_pass main_pass = 99;
  uint32_t variant = 99;
  const char* wanted[] = {"TINT", "QUALITY_LOW"};
  kiln_code code;
  const kiln_reflection *vertex, *fragment;
  kiln_resource resource;
  kiln_push_constant push;
  kiln_stage_variable input;
  kiln_gl_sampler sampler;
  kiln_gl_block block;
  kiln_msl_resource msl;
  uint32_t i;
  int found_albedo = 0;

  CHECK(kiln_pass_find(pack, "Main", &main_pass, &error) == KILN_OK);
  CHECK(kiln_select_by_names(pack, "Main", wanted, 2, 0, &variant, &error) == KILN_OK);
  CHECK(strcmp(kiln_pack_name(pack), "tiny") == 0);
  CHECK(kiln_variant_keyword_count(pack, main_pass, variant) == 2);
  CHECK(strcmp(kiln_variant_keyword(pack, main_pass, variant, 0), "QUALITY_LOW") == 0);
  CHECK(strcmp(kiln_variant_keyword(pack, main_pass, variant, 1), "TINT") == 0);
  CHECK(kiln_variant_keyword(pack, main_pass, variant, 2) == NULL);

  CHECK(kiln_variant_code(pack, main_pass, variant, KILN_STAGE_VERTEX, KILN_TARGET_SPIRV, &code, &error) == KILN_OK);
  CHECK(code.size >= 20 && code.size % 4 == 0 && *(const uint32_t*)code.bytes == 0x07230203u); /* SPIR-V magic */
  CHECK(kiln_variant_code(pack, main_pass, variant, KILN_STAGE_FRAGMENT, KILN_TARGET_GLSL, &code, &error) == KILN_OK);
  CHECK(code.size > 13 && memcmp(code.bytes, "#version 450", 12) == 0);
  CHECK(kiln_variant_code(pack, main_pass, variant, KILN_STAGE_FRAGMENT, KILN_TARGET_GLES, &code, &error) == KILN_OK);
  CHECK(code.size > 13 && memcmp(code.bytes, "#version 310 es", 15) == 0);
  CHECK(kiln_variant_code(pack, main_pass, variant, KILN_STAGE_FRAGMENT, KILN_TARGET_MSL, &code, &error) == KILN_OK);
  CHECK(code.size > 0 && strstr((const char*)code.bytes, "metal_stdlib") != NULL);
  CHECK_ERROR(kiln_variant_code(pack, main_pass, variant, KILN_STAGE_FRAGMENT, (kiln_target)7, &code, &error), &error,
              KILN_ERROR_INVALID_ARGUMENT, NULL);
  CHECK_ERROR(kiln_variant_code(pack, main_pass, 1000, KILN_STAGE_FRAGMENT, KILN_TARGET_SPIRV, &code, &error), &error,
              KILN_ERROR_INVALID_ARGUMENT, NULL);
  CHECK(strcmp(kiln_variant_entry_point(pack, main_pass, variant, KILN_STAGE_VERTEX), "Vert") == 0);
  CHECK(strcmp(kiln_variant_entry_point(pack, main_pass, variant, KILN_STAGE_FRAGMENT), "Frag") == 0);

  vertex = kiln_variant_reflection(pack, main_pass, variant, KILN_STAGE_VERTEX);
  fragment = kiln_variant_reflection(pack, main_pass, variant, KILN_STAGE_FRAGMENT);
  CHECK(vertex && fragment && kiln_reflection_stage(fragment) == KILN_STAGE_FRAGMENT);

  /* Vertex: the constant buffer, and the vertex inputs' locations and formats. */
  CHECK(kiln_reflection_resource_count(vertex) == 1);
  CHECK(kiln_reflection_resource(vertex, 0, &resource));
  CHECK(strcmp(resource.name, "PerDraw") == 0 && resource.kind == KILN_RESOURCE_UNIFORM_BUFFER && resource.set == 0 &&
        resource.binding == 0 && resource.count == 1 && resource.size == 80 && resource.stage_flags == KILN_STAGE_FLAG_VERTEX);
  CHECK(!kiln_reflection_resource(vertex, 1, &resource));
  CHECK(kiln_reflection_input_count(vertex) == 2);
  CHECK(kiln_reflection_input(vertex, 0, &input));
  CHECK(input.location == 0 && strcmp(input.type, "float3") == 0 && input.scalar == KILN_SCALAR_FLOAT && input.components == 3);
  CHECK(strcmp(input.semantic, "POSITION") == 0); /* the HLSL semantic, by which an engine binds its vertex streams */
  CHECK(kiln_reflection_input(vertex, 1, &input));
  CHECK(input.location == 1 && input.scalar == KILN_SCALAR_FLOAT && input.components == 2);
  CHECK(strcmp(input.semantic, "TEXCOORD0") == 0);
  CHECK(kiln_reflection_output_count(vertex) == 1);

  /* Fragment: the texture and sampler, the push constants TINT uses. */
  CHECK(kiln_reflection_resource_count(fragment) == 3);
  for (i = 0; kiln_reflection_resource(fragment, i, &resource); ++i) {
    CHECK(resource.stage_flags == KILN_STAGE_FLAG_FRAGMENT);
    if (strcmp(resource.name, "Albedo") == 0) {
      found_albedo = 1;
      CHECK(resource.kind == KILN_RESOURCE_TEXTURE && resource.set == 0 && resource.binding == 1 &&
            strcmp(resource.dimension, "2D") == 0 && !resource.depth);
    }
  }
  CHECK(found_albedo);
  CHECK(kiln_reflection_push_constant_count(fragment) == 1);
  CHECK(kiln_reflection_push_constant(fragment, 0, &push));
  CHECK(push.size == 16 && push.stage_flags == KILN_STAGE_FLAG_FRAGMENT);

  /* GL: one combined sampler at the texture's binding, the block by name; MSL indices. */
  CHECK(kiln_reflection_gl_sampler_count(fragment, 0) == 1 && kiln_reflection_gl_sampler_count(fragment, 1) == 1);
  CHECK(kiln_reflection_gl_sampler(fragment, 1, 0, &sampler));
  CHECK(strcmp(sampler.name, "Albedo_AlbedoSampler") == 0 && strcmp(sampler.texture, "Albedo") == 0 &&
        strcmp(sampler.sampler, "AlbedoSampler") == 0 && sampler.binding == 1);
  CHECK(kiln_reflection_gl_block_count(fragment, 0) == 1);
  CHECK(kiln_reflection_gl_block(fragment, 0, 0, &block));
  CHECK(strcmp(block.name, "PerDraw") == 0 && block.kind == KILN_RESOURCE_UNIFORM_BUFFER && block.binding == 0);
  CHECK(kiln_reflection_msl_resource_count(fragment) == 3);
  CHECK(kiln_reflection_msl_resource(fragment, 0, &msl));
  CHECK(strcmp(msl.name, "Albedo") == 0 && msl.kind == KILN_MSL_TEXTURE && msl.index == 0);
  CHECK(kiln_reflection_resource_count(NULL) == 0 && !kiln_reflection_resource(NULL, 0, &resource));
}

/* Buffer<T>, RWBuffer<T> and SubpassInput each have a kind of their own (not a texture, a storage image, nothing),
 * and the input attachment its index: what a loader builds its descriptor set layout and subpass from. */
static void test_texel_buffers_and_input_attachments(const char* pack_dir) {
  kiln_pack* pack = NULL;
  kiln_error error;
  kiln_pass pass = 99;
  uint32_t variant = 99;
  const kiln_reflection* fragment;
  kiln_resource resource;
  uint32_t i;
  int uniform_texel = 0, storage_texel = 0, attachment = 0;
  if (kiln_pack_open(pack_dir, &pack, &error) != KILN_OK) {
    fprintf(stderr, "%s: %s: %s\n", error.file, kiln_result_name(error.code), error.message);
    ++failures;
    return;
  }
  CHECK(kiln_pass_find(pack, "Texels", &pass, &error) == KILN_OK);
  CHECK(kiln_select_by_names(pack, "Texels", NULL, 0, 0, &variant, &error) == KILN_OK);
  fragment = kiln_variant_reflection(pack, pass, variant, KILN_STAGE_FRAGMENT);
  CHECK(fragment != NULL);
  CHECK(kiln_reflection_resource_count(fragment) == 3);
  for (i = 0; kiln_reflection_resource(fragment, i, &resource); ++i) {
    CHECK(resource.stage_flags == KILN_STAGE_FLAG_FRAGMENT && resource.set == 0 && resource.count == 1);
    if (strcmp(resource.name, "LightColors") == 0) {
      uniform_texel = 1;
      CHECK(resource.kind == KILN_RESOURCE_UNIFORM_TEXEL_BUFFER && resource.binding == 0 && resource.input_attachment_index == 0);
    } else if (strcmp(resource.name, "Counters") == 0) {
      storage_texel = 1;
      CHECK(resource.kind == KILN_RESOURCE_STORAGE_TEXEL_BUFFER && resource.binding == 1 && resource.input_attachment_index == 0);
    } else if (strcmp(resource.name, "GBufferAlbedo") == 0) {
      attachment = 1;
      CHECK(resource.kind == KILN_RESOURCE_INPUT_ATTACHMENT && resource.binding == 3 && resource.input_attachment_index == 2);
    } else {
      fprintf(stderr, "%s:%d: unexpected resource %s\n", __FILE__, __LINE__, resource.name);
      ++failures;
    }
  }
  CHECK(uniform_texel && storage_texel && attachment);
  kiln_pack_close(pack);
}

int main(int argc, char** argv) {
  kiln_pack* pack = NULL;
  kiln_error error;
  if (argc != 3 && argc != 4) {
    fprintf(stderr, "usage: %s <pack dir> <scratch dir> [<texels pack dir>]\n", argv[0]);
    return 2;
  }
  test_open_failures(argv[1], argv[2]);
  if (kiln_pack_open(argv[1], &pack, &error) != KILN_OK) {
    fprintf(stderr, "%s: %s: %s\n", error.file, kiln_result_name(error.code), error.message);
    return 1;
  }
  CHECK(error.code == KILN_OK && error.message[0] == '\0');
  CHECK(kiln_pass_count(pack) == 2 && strcmp(kiln_pass_name(pack, 1), "Depth") == 0 && kiln_pass_name(pack, 2) == NULL);
  CHECK(kiln_keyword_count(pack) == 5); /* ALPHA_CLIP FOG QUALITY_HIGH QUALITY_LOW TINT */
  CHECK(strcmp(kiln_keyword_name(pack, 0), "ALPHA_CLIP") == 0);
  CHECK(kiln_pass_group_count(pack, 0) == 3 && kiln_pass_group_value_count(pack, 0, 0) == 2);
  CHECK(strcmp(kiln_pass_group_value(pack, 0, 0, 0), "") == 0 && strcmp(kiln_pass_group_value(pack, 0, 0, 1), "FOG") == 0);
  test_selection_errors(pack);
  test_selection_by_ids_equals_by_names(pack);
  test_variant_contents(pack);
  kiln_pack_close(pack);
  if (argc == 4) test_texel_buffers_and_input_attachments(argv[3]);
  kiln_pack_close(NULL);
  if (failures) fprintf(stderr, "%d checks failed\n", failures);
  else printf("all checks passed\n");
  return failures != 0;
}
