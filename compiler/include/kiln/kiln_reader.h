/* SPDX-License-Identifier: Apache-2.0 */
/* kiln's runtime pack reader as a C API: for C, and for C++ built with -fno-exceptions or without RTTI. It wraps
 * kiln::PackReader (pack_reader.hpp), checks packs the same way, selects by the same rule and reports the same
 * errors, as codes with messages; no C++ exception ever leaves it. C99; link with the kiln_reader library
 * (CMake: kiln::reader; pkg-config: kiln-reader).
 *
 *   kiln_error error;
 *   kiln_pack* pack;
 *   if (kiln_pack_open("packs/lit", &pack, &error) != KILN_OK) { fprintf(stderr, "%s: %s\n", error.file, error.message); ... }
 *   kiln_pass forward;                       // look names up once, at load time
 *   kiln_keyword fog, soft;
 *   kiln_pass_find(pack, "Forward", &forward, &error);
 *   kiln_keyword_find(pack, "FOG_EXP", &fog, &error);
 *   kiln_keyword_find(pack, "_SHADOWS_SOFT", &soft, &error);
 *   kiln_keyword wanted[] = {fog, soft};     // then select per draw, with no string work
 *   uint32_t variant;
 *   if (kiln_select(pack, forward, wanted, 2, 0, &variant, &error) == KILN_OK) {
 *     kiln_code spirv;
 *     kiln_variant_code(pack, forward, variant, KILN_STAGE_FRAGMENT, KILN_TARGET_SPIRV, &spirv, &error);
 *   }
 *   kiln_pack_close(pack);
 *
 * Selection rule (pack_reader.hpp's, unchanged): keywords the pass does not declare are ignored, unless `strict`
 * (then KILN_ERROR_UNKNOWN_KEYWORD); two keywords of one group are KILN_ERROR_CONFLICTING_KEYWORDS; a group with
 * no keyword given takes its off value, and a group without one needs a keyword (KILN_ERROR_MISSING_KEYWORD); a
 * combination stripped from the pack is KILN_ERROR_STRIPPED, whose message names the nearest variants that exist.
 * There is never a silent "closest match".
 *
 * Ownership and lifetime: kiln_pack_open allocates the pack; kiln_pack_close frees it. Every pointer the API
 * returns (names, entry points, code bytes, reflection handles and the strings in reflection records) is owned
 * by the pack and stays valid, unchanged, until kiln_pack_close (after a pack switch by kiln_pack_poll_update:
 * until the next kiln_pack_poll_update call, see there). The caller owns kiln_error and the arrays it passes; the
 * API keeps no pointer to them.
 *
 * Threads: an open pack is read-only. Any number of threads may call any function on one pack at once (a
 * compressed blob is decompressed once, under a lock, on first use), except kiln_pack_close, which must come
 * after all of them, and kiln_pack_poll_update, which must not overlap any other call on the pack either. Errors go
 * to the kiln_error the caller passes to each call, so there is no shared "last error" to race on. Every
 * `kiln_error* error` parameter may be NULL (the code is still returned).
 */
#ifndef KILN_READER_H
#define KILN_READER_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define KILN_READER_API_VERSION 1

/* The first nine mirror kiln::PackError::Code, in its order. */
typedef enum kiln_result {
  KILN_OK = 0,
  KILN_ERROR_IO = 1,                    /* a file is missing, unreadable, or not a regular file */
  KILN_ERROR_FORMAT = 2,                /* malformed manifest or archive */
  KILN_ERROR_VERSION = 3,               /* a pack format this reader does not read */
  KILN_ERROR_CHECKSUM = 4,              /* the manifest, the archive or a blob fails its checksum */
  KILN_ERROR_UNKNOWN_PASS = 5,          /* no pass of that name */
  KILN_ERROR_UNKNOWN_KEYWORD = 6,       /* strict selection: a keyword the pass does not declare; or a name no pass declares */
  KILN_ERROR_CONFLICTING_KEYWORDS = 7,  /* two keywords of one group */
  KILN_ERROR_MISSING_KEYWORD = 8,       /* a group without an off value got no keyword */
  KILN_ERROR_STRIPPED = 9,              /* the combination was stripped from the pack */
  KILN_ERROR_OUT_OF_MEMORY = 10,
  KILN_ERROR_INVALID_ARGUMENT = 11      /* a NULL pointer, or a pass, keyword, variant, stage or target out of range */
} kiln_result;

/* Filled by every call that takes one: code, and on failure the message and, when the error is about a file, the
 * file ("out/lit.manifest.json:3:1", "out/lit.<xxh3>.kpack"; empty otherwise). Both NUL-terminated, truncated to fit. */
typedef struct kiln_error {
  kiln_result code;
  char file[512];
  char message[1024];
} kiln_error;

/* "io", "format", ..., "stripped", "out of memory", "invalid argument"; "ok" for KILN_OK. Static strings. */
const char* kiln_result_name(kiln_result code);

typedef struct kiln_pack kiln_pack;             /* an open pack (opaque) */
typedef struct kiln_reflection kiln_reflection; /* one compiled stage's reflection (opaque, owned by the pack) */
typedef uint32_t kiln_pass;                     /* a pass: 0 .. kiln_pass_count() - 1, in the manifest's order */
typedef uint32_t kiln_keyword;                  /* a keyword declared by any pass of the pack: 0 .. kiln_keyword_count() - 1, by name */

/* Hull and domain are HLSL's tessellation control and evaluation stages. */
typedef enum kiln_stage {
  KILN_STAGE_VERTEX = 0,
  KILN_STAGE_FRAGMENT = 1,
  KILN_STAGE_COMPUTE = 2,
  KILN_STAGE_GEOMETRY = 3,
  KILN_STAGE_HULL = 4,
  KILN_STAGE_DOMAIN = 5
} kiln_stage;
/* Stage flags, as in Vulkan's VkShaderStageFlagBits. */
enum {
  KILN_STAGE_FLAG_VERTEX = 0x1,
  KILN_STAGE_FLAG_HULL = 0x2,   /* VK_SHADER_STAGE_TESSELLATION_CONTROL_BIT */
  KILN_STAGE_FLAG_DOMAIN = 0x4, /* VK_SHADER_STAGE_TESSELLATION_EVALUATION_BIT */
  KILN_STAGE_FLAG_GEOMETRY = 0x8,
  KILN_STAGE_FLAG_FRAGMENT = 0x10,
  KILN_STAGE_FLAG_COMPUTE = 0x20
};
/* One per row of kiln/targets.def, in its order from 0 (each row's description says what the code is):
   KILN_TARGET_SPIRV (SPIR-V words, for vkCreateShaderModule), KILN_TARGET_GLSL (GLSL 450 source text, not
   NUL-terminated: use the size), KILN_TARGET_GLES (GLSL ES 3.10), KILN_TARGET_MSL (MSL 2.1). */
typedef enum kiln_target {
#define KILN_TARGET(Enumerator, id, extension, other_extensions, C_NAME, emit, library, description) KILN_TARGET_##C_NAME,
#include "kiln/targets.def"
  KILN_TARGET_COUNT /* not a target: how many there are */
} kiln_target;

/* ---- Opening ------------------------------------------------------------------------------------------------ */

/* `path` is a `<name>.manifest.json` or a directory holding exactly one. On success *pack is the open pack; on
 * failure it is NULL and the code is IO, FORMAT, VERSION, CHECKSUM, OUT_OF_MEMORY or INVALID_ARGUMENT. The archive
 * is mapped, not read: opening checks its header, blob table and runtime index; each blob's checksum is checked
 * when kiln_variant_code first returns it (a damaged blob is KILN_ERROR_CHECKSUM then). A pack written by an older
 * kiln is KILN_ERROR_VERSION ("rebuild the pack with this version of kiln"). */
kiln_result kiln_pack_open(const char* path, kiln_pack** pack, kiln_error* error);
void kiln_pack_close(kiln_pack* pack); /* NULL is allowed; writes the usage log when recording */
const char* kiln_pack_name(const kiln_pack* pack);

/* ---- Usage recording (docs/usage.md) ----------------------------------------------------------------------- */

/* From this call on, every kiln_select and kiln_select_by_names is counted: each variant served, and each keyword
 * set the pack lacks (KILN_ERROR_STRIPPED) with the nearest variant. The log is written to `path` (atomically) by
 * kiln_pack_flush_usage and by kiln_pack_close. `tags` are `tag_count` "key=value" strings the game labels the run
 * with (a scene, a level, a build), or NULL. A served selection costs one atomic increment; thread-safe. Calling it
 * again changes the path and tags and keeps the counts. INVALID_ARGUMENT for a NULL pack or path or a tag without
 * '='. */
kiln_result kiln_pack_record_usage(kiln_pack* pack, const char* path, const char* const* tags, size_t tag_count,
                                   kiln_error* error);
/* Writes the usage log now (IO when it cannot be written; OK and nothing written when not recording). */
kiln_result kiln_pack_flush_usage(const kiln_pack* pack, kiln_error* error);

/* ---- Live updates (docs/reader.md, "Live updates") --------------------------------------------------------- */

/* What kiln_pack_poll_update found: whether the pack now serves a newer build of itself, and which variants that
 * changed, matched by pass name and keyword set. "Changed" is binary identity: per stage the entry point, each
 * target's code checksum and the reflection, and the folded keywords' values. A variant equal in all of them at the
 * same index is not listed: its pipeline carries over. */
typedef enum kiln_variant_change_kind {
  KILN_VARIANT_ADDED = 1,   /* a keyword set the previous pack lacked (kiln_select used to fail with STRIPPED) */
  KILN_VARIANT_CHANGED = 2, /* the same keyword set with other code: recreate its pipeline */
  KILN_VARIANT_REMOVED = 3, /* a keyword set the new pack lacks (kiln_select now fails with STRIPPED) */
  KILN_VARIANT_MOVED = 4    /* the same code at another variant index: keep the pipeline, re-key it if keyed by index */
} kiln_variant_change_kind;
#define KILN_NO_INDEX UINT32_MAX /* no such pass or variant on that side of the switch */
typedef struct kiln_variant_change {
  kiln_variant_change_kind kind;
  const char* pass;                 /* the pass's name */
  kiln_pass old_pass, new_pass;     /* the pass's id before and after the switch; KILN_NO_INDEX where it has none */
  uint32_t old_variant;             /* the variant index before the switch; KILN_NO_INDEX when ADDED */
  uint32_t new_variant;             /* the variant index after the switch; KILN_NO_INDEX when REMOVED */
  const char* const* keywords;      /* its keywords, sorted; NULL when keyword_count is 0 */
  uint32_t keyword_count;
} kiln_variant_change;
typedef struct kiln_pack_update {
  int switched;        /* 1: the pack serves the newer build from now on; 0: nothing new, the rest is empty */
  int ids_changed;     /* 1: passes or keywords were added, removed or reordered: look kiln_pass and kiln_keyword
                          ids up again (kiln_pass_find, kiln_keyword_find) */
  uint64_t version;    /* the version served after this call: 1 as opened, one more per switch */
  const char* archive; /* the archive served after this call, "<name>.<xxh3>.kpack" */
  const kiln_variant_change* changes; /* by pass (the new pack's order, then passes it dropped), then keywords */
  size_t change_count;
} kiln_pack_update;

/* Looks at the manifest the pack was opened from: when a build has replaced it (kiln renames the new archive, then
 * the new manifest, into place), opens the new pack with kiln_pack_open's checks and switches the pack to it. Nothing
 * new costs one stat() of the manifest. A damaged or incomplete new pack is refused with its error (IO, FORMAT,
 * VERSION, CHECKSUM, OUT_OF_MEMORY; reported once: later calls say nothing new until its files change again) and the
 * previous pack keeps serving; *update then says nothing new.
 *
 * Memory: *update and everything it points to belong to the pack, valid until the next kiln_pack_poll_update or
 * kiln_pack_close. After a switch, the pack's ids (when ids_changed), variant indices, names, code bytes and
 * reflection handles are the new pack's; those handed out before the switch stay valid until the next
 * kiln_pack_poll_update call. So poll once per frame where no other call on the pack is running and the last frame
 * is done with what the pack handed out, then recreate what `changes` lists.
 *
 * Threads: not at the same time as any other call on the same pack (ids and indices from one call feed the next, so
 * a switch has to happen between a game's calls, not inside a sequence of them). Usage recording carries over: the
 * log counts each keyword set's selections from every version served. */
kiln_result kiln_pack_poll_update(kiln_pack* pack, kiln_pack_update* update, kiln_error* error);
/* A file descriptor (inotify, non-blocking) that becomes readable when a file in the pack's directory is replaced:
 * put it in the game's poll set and call kiln_pack_poll_update when it is (which drains it). Owned by the pack,
 * closed by kiln_pack_close; the same one on every call. IO when inotify is not available. */
kiln_result kiln_pack_update_fd(kiln_pack* pack, int* fd, kiln_error* error);

/* ---- Passes and keywords: look names up once --------------------------------------------------------------- */

uint32_t kiln_pass_count(const kiln_pack* pack);
const char* kiln_pass_name(const kiln_pack* pack, kiln_pass pass); /* NULL when out of range */
kiln_result kiln_pass_find(const kiln_pack* pack, const char* name, kiln_pass* pass, kiln_error* error); /* UNKNOWN_PASS */

uint32_t kiln_keyword_count(const kiln_pack* pack);
const char* kiln_keyword_name(const kiln_pack* pack, kiln_keyword keyword); /* NULL when out of range */
/* UNKNOWN_KEYWORD when no pass of the pack declares the name (a keyword for another pack: leave it out). */
kiln_result kiln_keyword_find(const kiln_pack* pack, const char* name, kiln_keyword* keyword, kiln_error* error);

/* A pass's keyword groups; a group's values are keyword names, "" being the off value. */
uint32_t kiln_pass_group_count(const kiln_pack* pack, kiln_pass pass);
uint32_t kiln_pass_group_value_count(const kiln_pack* pack, kiln_pass pass, uint32_t group);
const char* kiln_pass_group_value(const kiln_pack* pack, kiln_pass pass, uint32_t group, uint32_t value);

/* ---- Selection ------------------------------------------------------------------------------------------------ */

/* Selects the variant of `pass` for `keywords` (count of them; repeats allowed; NULL when count is 0) and stores
 * its index (0 .. kiln_variant_count() - 1) in *variant. Precomputed at open: a successful selection does no
 * string work and allocates nothing (unit.capi.FromCxxWithoutExceptionsSelectionByIdsAllocatesNothing counts). A
 * failed one costs what the C++ reader's does, and fails with its code and message. */
kiln_result kiln_select(const kiln_pack* pack, kiln_pass pass, const kiln_keyword* keywords, size_t count, int strict,
                        uint32_t* variant, kiln_error* error);
/* The same by names, exactly as kiln::PackReader::select (also UNKNOWN_PASS); strings are compared on every call. */
kiln_result kiln_select_by_names(const kiln_pack* pack, const char* pass, const char* const* keywords, size_t count,
                                 int strict, uint32_t* variant, kiln_error* error);

/* ---- A variant: its keywords, and per stage its code, entry point and reflection ----------------------------- */

uint32_t kiln_variant_count(const kiln_pack* pack, kiln_pass pass);
uint32_t kiln_variant_keyword_count(const kiln_pack* pack, kiln_pass pass, uint32_t variant);
const char* kiln_variant_keyword(const kiln_pack* pack, kiln_pass pass, uint32_t variant, uint32_t index); /* sorted */

typedef struct kiln_code {
  const void* bytes; /* NULL and size 0 when the variant has no such stage or the pack was not built for the target */
  size_t size;
} kiln_code;
/* A compressed blob is decompressed on first use: that may fail with CHECKSUM, FORMAT or OUT_OF_MEMORY. */
kiln_result kiln_variant_code(const kiln_pack* pack, kiln_pass pass, uint32_t variant, kiln_stage stage,
                              kiln_target target, kiln_code* code, kiln_error* error);
/* Folded keywords (dynamic_branch, specialization_constant and specialization_constant_int groups,
 * docs/keywords.md): variants that differ only in them share their code, and the game sets the difference. A pass
 * has kiln_pass_value_count() of them, the same for every variant; kiln_variant_value() says where value `index`
 * goes, whether it is on for `variant`, and the number to set there:
 *   KILN_KEYWORD_SPECIALIZATION_CONSTANT: a VkBool32 specialization constant `slot` (VkSpecializationMapEntry
 *     constantID) of the stages in stage_flags, `value` 1 or 0; GLSL/GLSL ES: `#define SPIRV_CROSS_CONSTANT_ID_<slot>
 *     true|false` after the #version line; MSL: function constant `slot`.
 *   KILN_KEYWORD_SPECIALIZATION_INTEGER: an int32 specialization constant `slot`, shared by every value of its group,
 *     the off value too (keyword ""). Exactly one of them is on: set `slot` to its `value` and skip the others
 *     (GLSL/GLSL ES: `#define SPIRV_CROSS_CONSTANT_ID_<slot> <value>`).
 *   KILN_KEYWORD_DYNAMIC_BRANCH: a 4-byte `value`, 0 or 1, at byte offset `slot` of the uniform block
 *     KILN_KEYWORD_BLOCK (set KILN_KEYWORD_BLOCK_SET, binding KILN_KEYWORD_BLOCK_BINDING; its reflection lists it),
 *     before the draw.
 * A slot is derived from the pack, which may be damaged or hostile: before writing a dynamic-branch value, check
 * that `slot` + 4 is at most the `size` of the stage's KILN_KEYWORD_BLOCK resource (kiln_reflection) and of the
 * buffer you bound for it; skip a value that does not fit. */
typedef enum kiln_keyword_kind {
  KILN_KEYWORD_DYNAMIC_BRANCH = 1,
  KILN_KEYWORD_SPECIALIZATION_CONSTANT = 2,
  KILN_KEYWORD_SPECIALIZATION_INTEGER = 3
} kiln_keyword_kind;
#define KILN_KEYWORD_BLOCK "_KilnKeywords"
#define KILN_KEYWORD_BLOCK_SET 0
#define KILN_KEYWORD_BLOCK_BINDING 62
typedef struct kiln_keyword_value {
  const char* keyword;  /* "" for the off value of an int group */
  kiln_keyword_kind kind;
  uint32_t stage_flags; /* KILN_STAGE_FLAG_*: the stages whose code declares it */
  uint32_t slot;        /* the constant id, or the byte offset in the block */
  uint32_t on;          /* 1 or 0 */
  uint32_t value;       /* what to set at `slot` (an int group's: only from the value that is on) */
} kiln_keyword_value;
uint32_t kiln_pass_value_count(const kiln_pack* pack, kiln_pass pass); /* 0 for a pass without folded keywords */
/* Value `index` alone. Each call works out the whole pass's values (O(F log K) for F values and K keywords of the
 * variant): to read them all, call kiln_variant_values once. */
kiln_result kiln_variant_value(const kiln_pack* pack, kiln_pass pass, uint32_t variant, uint32_t index,
                               kiln_keyword_value* value, kiln_error* error);
/* Every value at once, in the order of kiln_variant_value's index, into values[0 .. kiln_pass_value_count() - 1]
 * (the same cost as one kiln_variant_value call). INVALID_ARGUMENT, nothing written, when `capacity` is smaller
 * than the count; `values` may be NULL for a pass without folded keywords. */
kiln_result kiln_variant_values(const kiln_pack* pack, kiln_pass pass, uint32_t variant, kiln_keyword_value* values,
                                uint32_t capacity, kiln_error* error);

/* The entry point the stage's code has (the manifest's binary record); NULL when the variant has no such stage. */
const char* kiln_variant_entry_point(const kiln_pack* pack, kiln_pass pass, uint32_t variant, kiln_stage stage);
/* NULL when the variant has no such stage (or its reflection record does not decode, or no memory is left to decode
 * it: records are decoded on first use). Variants that share a binary share its reflection. */
const kiln_reflection* kiln_variant_reflection(const kiln_pack* pack, kiln_pass pass, uint32_t variant, kiln_stage stage);

/* ---- Reflection: what a stage binds (enough for a Vulkan pipeline layout), and each target's bindings ------- */

/* One per Vulkan descriptor type (VK_DESCRIPTOR_TYPE_*); values are never renumbered, new kinds are appended. */
typedef enum kiln_resource_kind {
  KILN_RESOURCE_UNIFORM_BUFFER = 0,         /* UNIFORM_BUFFER: cbuffer, ConstantBuffer<T> */
  KILN_RESOURCE_STORAGE_BUFFER = 1,         /* STORAGE_BUFFER: (RW)StructuredBuffer, (RW)ByteAddressBuffer */
  KILN_RESOURCE_TEXTURE = 2,                /* SAMPLED_IMAGE: a separate (sampled) image, Texture2D etc.; never Buffer<T> */
  KILN_RESOURCE_SAMPLER = 3,                /* SAMPLER */
  KILN_RESOURCE_COMBINED_IMAGE_SAMPLER = 4, /* COMBINED_IMAGE_SAMPLER */
  KILN_RESOURCE_STORAGE_IMAGE = 5,          /* STORAGE_IMAGE: RWTexture2D etc.; never RWBuffer<T> */
  KILN_RESOURCE_UNIFORM_TEXEL_BUFFER = 6,   /* UNIFORM_TEXEL_BUFFER: Buffer<T> (older packs: TEXTURE, "Buffer") */
  KILN_RESOURCE_STORAGE_TEXEL_BUFFER = 7,   /* STORAGE_TEXEL_BUFFER: RWBuffer<T> (older packs: STORAGE_IMAGE, "Buffer") */
  KILN_RESOURCE_INPUT_ATTACHMENT = 8        /* INPUT_ATTACHMENT: SubpassInput, SubpassInputMS; see input_attachment_index */
} kiln_resource_kind;

typedef struct kiln_resource {
  const char* name;
  kiln_resource_kind kind;
  uint32_t set;
  uint32_t binding;
  uint32_t count;       /* array size (descriptorCount) */
  uint32_t stage_flags; /* KILN_STAGE_FLAG_*: the reflected stage's; OR them over the stages for a pipeline layout */
  uint64_t size;        /* blocks: the declared size in bytes; 0 otherwise */
  const char* dimension; /* images: "1D", "2D", "2DArray", "3D", "Cube", "CubeArray"; "" otherwise */
  int depth;            /* images: depth comparison */
  uint32_t input_attachment_index; /* input attachments: [[vk::input_attachment_index(N)]]; 0 otherwise */
} kiln_resource;

typedef struct kiln_push_constant {
  const char* name;
  uint64_t size; /* bytes, from offset 0 */
  uint32_t stage_flags;
} kiln_push_constant;

typedef enum kiln_scalar { KILN_SCALAR_UNKNOWN = 0, KILN_SCALAR_FLOAT, KILN_SCALAR_HALF, KILN_SCALAR_INT, KILN_SCALAR_UINT, KILN_SCALAR_BOOL } kiln_scalar;

/* A stage input or output: a vertex input's location and format (scalar x components: float3 is FLOAT x 3,
 * VK_FORMAT_R32G32B32_SFLOAT). `type` is the reflected HLSL-style name ("float4"); unknown forms have scalar UNKNOWN. */
typedef struct kiln_stage_variable {
  const char* name;
  uint32_t location;
  const char* type;
  kiln_scalar scalar;
  uint32_t components; /* 1-4; 0 when the type is not a scalar or vector */
  const char* semantic; /* the HLSL semantic, upper case ("POSITION", "TEXCOORD0"); "" when none */
} kiln_stage_variable;

/* GLSL and GLSL ES bindings: HLSL's separate textures and samplers become combined samplers, each at its texture's
 * binding; blocks are bound by the interface name glGetUniformBlockIndex takes. */
typedef struct kiln_gl_sampler {
  const char* name; /* "<texture>_<sampler>"; the sampler is "kiln_no_sampler" for Load/GetDimensions */
  const char* texture;
  const char* sampler;
  uint32_t binding;
} kiln_gl_sampler;
typedef struct kiln_gl_block {
  const char* name;
  kiln_resource_kind kind; /* uniform or storage buffer */
  uint32_t binding;
} kiln_gl_block;

typedef enum kiln_msl_kind { KILN_MSL_BUFFER = 0, KILN_MSL_TEXTURE = 1, KILN_MSL_SAMPLER = 2 } kiln_msl_kind;
typedef struct kiln_msl_resource {
  const char* name; /* as the HLSL declares it */
  kiln_msl_kind kind;
  uint32_t index;   /* [[buffer(n)]], [[texture(n)]] or [[sampler(n)]] */
} kiln_msl_resource;

/* Each accessor takes an index below its count and returns 1 with *out filled, or 0 (out of range, or a NULL
 * argument) with *out untouched. Records are in the manifest's order (resources by set and binding). */
kiln_stage kiln_reflection_stage(const kiln_reflection* reflection);
/* A compute stage's thread-group size ([numthreads(x, y, z)]): returns 1 with size[0..2] filled, or 0 (not a compute
 * stage, or a NULL argument) with size untouched. */
int kiln_reflection_local_size(const kiln_reflection* reflection, uint32_t size[3]);
uint32_t kiln_reflection_resource_count(const kiln_reflection* reflection);
int kiln_reflection_resource(const kiln_reflection* reflection, uint32_t index, kiln_resource* out);
uint32_t kiln_reflection_push_constant_count(const kiln_reflection* reflection);
int kiln_reflection_push_constant(const kiln_reflection* reflection, uint32_t index, kiln_push_constant* out);
uint32_t kiln_reflection_input_count(const kiln_reflection* reflection);
int kiln_reflection_input(const kiln_reflection* reflection, uint32_t index, kiln_stage_variable* out);
uint32_t kiln_reflection_output_count(const kiln_reflection* reflection);
int kiln_reflection_output(const kiln_reflection* reflection, uint32_t index, kiln_stage_variable* out);
/* `es`: 0 for GLSL 450's records, 1 for GLSL ES's; the counts are 0 when the pack was not built for the target. */
uint32_t kiln_reflection_gl_sampler_count(const kiln_reflection* reflection, int es);
int kiln_reflection_gl_sampler(const kiln_reflection* reflection, int es, uint32_t index, kiln_gl_sampler* out);
uint32_t kiln_reflection_gl_block_count(const kiln_reflection* reflection, int es);
int kiln_reflection_gl_block(const kiln_reflection* reflection, int es, uint32_t index, kiln_gl_block* out);
uint32_t kiln_reflection_msl_resource_count(const kiln_reflection* reflection);
int kiln_reflection_msl_resource(const kiln_reflection* reflection, uint32_t index, kiln_msl_resource* out);

#ifdef __cplusplus
}
#endif

#endif /* KILN_READER_H */
