// SPDX-License-Identifier: Apache-2.0
// kiln_reader.h: the C API over kiln::PackReader. Every entry point that can fail runs its body inside guarded(),
// which turns any exception into a code (std::bad_alloc into KILN_ERROR_OUT_OF_MEMORY), so none crosses into C.
//
// Selection by ids (kiln_select) is precomputed at open: each pass maps every pack keyword id to its group and
// value index, and every variant to one integer (its value indices in mixed radix), kept sorted. A call then reads
// the ids into a fixed array of group values, fills the off values and binary-searches the integer: no string is
// compared or built and nothing is allocated. Only a failing call (or a pass the table cannot encode: more than
// kMaxFastGroups groups, a radix over 64 bits) hands the names to PackReader::select, so that errors and their
// messages are the C++ reader's exactly. unit.CApi.* compares the two on every keyword set of awkward packs.
#include "kiln/kiln_reader.h"

#include <algorithm>
#include <array>
#include <cstdio>
#include <cstring>
#include <memory>
#include <new>
#include <string>
#include <string_view>
#include <vector>

#include <atomic>

#include "kiln/pack_reader.hpp"
#include "kiln/runtime_index.hpp"

// One per binary of the pack; its record is decoded when kiln_variant_reflection first hands it out.
struct kiln_reflection {
  std::atomic<const kiln::Reflection*> reflection{nullptr};
  uint32_t id = 0;  // the reflection record's
  kiln_stage stage = KILN_STAGE_VERTEX;
  uint32_t stage_flags = 0;
};

namespace {

using kiln::PackError;

// Vulkan's VkShaderStageFlagBits of a stage.
uint32_t stage_flag(kiln_stage stage) {
  switch (stage) {
    case KILN_STAGE_VERTEX: return KILN_STAGE_FLAG_VERTEX;
    case KILN_STAGE_FRAGMENT: return KILN_STAGE_FLAG_FRAGMENT;
    case KILN_STAGE_COMPUTE: return KILN_STAGE_FLAG_COMPUTE;
    case KILN_STAGE_GEOMETRY: return KILN_STAGE_FLAG_GEOMETRY;
    case KILN_STAGE_HULL: return KILN_STAGE_FLAG_HULL;
    case KILN_STAGE_DOMAIN: return KILN_STAGE_FLAG_DOMAIN;
  }
  return 0;
}

constexpr size_t kMaxFastGroups = 64;
constexpr uint32_t kNoValue = UINT32_MAX;

struct PassIndex {
  const kiln::runtime::Pass* pass = nullptr;
  // The pass's keywords, by pack keyword id: its group and its value index in that group. A table per pass as long
  // as the pack's keyword list made a game's open passes x keywords in time and memory (a hostile index of 100,000
  // passes and as many keywords asked for 80 GB); this one is as long as the pass's groups.
  struct KeywordPlace {
    uint32_t keyword, group, value;
  };
  std::vector<KeywordPlace> places;  // sorted by keyword, one per keyword
  const KeywordPlace* place_of(uint32_t keyword) const {
    auto it = std::lower_bound(places.begin(), places.end(), keyword,
                               [](const KeywordPlace& p, uint32_t k) { return p.keyword < k; });
    return it != places.end() && it->keyword == keyword ? &*it : nullptr;
  }
  std::vector<uint32_t> off_value;    // per group: the index of "" (kNoValue: none)
  std::vector<uint64_t> radix;        // per group: its place value in a variant's code
  std::vector<std::pair<uint64_t, uint32_t>> by_code;  // variant code -> variant index, sorted by code
  std::vector<uint8_t> one_value;     // per group: 1 when it has one value (always on without an off value)
  bool fast = true;                   // false: kiln_select goes through PackReader::select
};

}  // namespace

struct kiln_pack {
  kiln::PackReader reader;
  const kiln::runtime::Index* index = nullptr;  // the reader's
  std::vector<PassIndex> passes;                 // in the manifest's order
  std::unique_ptr<kiln_reflection[]> binaries;   // per binary
  std::shared_ptr<struct PackUpdates> updates;   // kiln_pack_poll_update's (below), made by its first call
};

namespace kiln {
// The C++ reader inside a C pack, for kiln/kiln_reader_dev.h (src/reader_dev/c_api.cpp), which is built apart.
PackReader& pack_reader_of(kiln_pack& pack) { return pack.reader; }
}  // namespace kiln

namespace {

void copy_text(char* to, size_t capacity, const char* from) {
  const size_t n = std::min(std::strlen(from), capacity - 1);
  std::memcpy(to, from, n);
  to[n] = '\0';
}

kiln_result fail(kiln_error* error, kiln_result code, const char* message, const char* file = "") {
  if (error) {
    error->code = code;
    copy_text(error->message, sizeof error->message, message);
    copy_text(error->file, sizeof error->file, file);
  }
  return code;
}

kiln_result ok(kiln_error* error) {
  if (error) {
    error->code = KILN_OK;
    error->message[0] = '\0';
    error->file[0] = '\0';
  }
  return KILN_OK;
}

kiln_result code_of(PackError::Code code) {
  switch (code) {
    case PackError::Code::Io: return KILN_ERROR_IO;
    case PackError::Code::Format: return KILN_ERROR_FORMAT;
    case PackError::Code::Version: return KILN_ERROR_VERSION;
    case PackError::Code::Checksum: return KILN_ERROR_CHECKSUM;
    case PackError::Code::UnknownPass: return KILN_ERROR_UNKNOWN_PASS;
    case PackError::Code::UnknownKeyword: return KILN_ERROR_UNKNOWN_KEYWORD;
    case PackError::Code::ConflictingKeywords: return KILN_ERROR_CONFLICTING_KEYWORDS;
    case PackError::Code::MissingKeyword: return KILN_ERROR_MISSING_KEYWORD;
    case PackError::Code::Stripped: return KILN_ERROR_STRIPPED;
    case PackError::Code::OutOfMemory: return KILN_ERROR_OUT_OF_MEMORY;
  }
  return KILN_ERROR_FORMAT;
}

// Runs `body` (which returns a kiln_result) with every exception turned into an error code.
template <class F>
kiln_result guarded(kiln_error* error, F&& body) noexcept {
  try {
    return body();
  } catch (const PackError& e) {
    return fail(error, code_of(e.code()), e.what(), e.file().c_str());
  } catch (const std::bad_alloc&) {
    return fail(error, KILN_ERROR_OUT_OF_MEMORY, "out of memory");
  } catch (const std::exception& e) {
    return fail(error, KILN_ERROR_FORMAT, e.what());
  } catch (...) {
    return fail(error, KILN_ERROR_FORMAT, "unknown internal error");
  }
}

template <class... Args>
kiln_result invalid(kiln_error* error, const char* format, Args... args) {
  if constexpr (sizeof...(Args) == 0) {
    return fail(error, KILN_ERROR_INVALID_ARGUMENT, format);
  } else {
    char message[256];
    std::snprintf(message, sizeof message, format, args...);
    return fail(error, KILN_ERROR_INVALID_ARGUMENT, message);
  }
}

const kiln::runtime::Variant* find_variant(const kiln_pack* pack, kiln_pass pass, uint32_t variant) {
  if (!pack || pass >= pack->passes.size()) return nullptr;
  const kiln::runtime::Pass& p = *pack->passes[pass].pass;
  return variant < p.variant_count ? &pack->index->variants[p.first_variant + variant] : nullptr;
}

// The binary id of a variant's stage, or kNone.
uint32_t find_binary(const kiln_pack* pack, kiln_pass pass, uint32_t variant, kiln_stage stage) {
  const kiln::runtime::Variant* v = find_variant(pack, pass, variant);
  if (!v || (static_cast<int>(stage) < 0 || static_cast<int>(stage) >= kiln::kStageCount)) return kiln::runtime::kNone;
  return v->binaries[static_cast<size_t>(stage)];
}

void index_pass(const kiln::runtime::Index& ix, PassIndex& index) {
  const kiln::runtime::Pass& pass = *index.pass;
  const size_t groups = pass.group_count;
  index.places.clear();
  index.off_value.assign(groups, kNoValue);
  index.radix.assign(groups, 0);
  index.one_value.assign(groups, 0);
  auto group = [&](size_t g) -> const kiln::runtime::Group& { return ix.groups[pass.first_group + g]; };
  for (size_t g = 0; g < groups; ++g) {
    index.one_value[g] = group(g).value_count == 1;
    for (uint32_t v = 0; v < group(g).value_count; ++v) {
      const uint32_t id = ix.values[group(g).first_value + v];
      if (id == kiln::runtime::kOffValue) index.off_value[g] = v;
      else index.places.push_back({id, static_cast<uint32_t>(g), v});
    }
  }
  // A keyword in two groups (or twice in one) belongs to its first place, as in PackReader::select.
  std::stable_sort(index.places.begin(), index.places.end(),
                   [](const auto& a, const auto& b) { return a.keyword < b.keyword; });
  index.places.erase(std::unique(index.places.begin(), index.places.end(),
                                 [](const auto& a, const auto& b) { return a.keyword == b.keyword; }),
                     index.places.end());
  uint64_t place = 1;
  index.fast = groups <= kMaxFastGroups;
  for (size_t g = 0; g < groups && index.fast; ++g) {
    index.radix[g] = place;
    const uint64_t size = group(g).value_count;
    if (size == 0 || place > UINT64_MAX / size) index.fast = false;
    else place *= size;
  }
  std::vector<std::pair<uint64_t, uint32_t>> codes;
  for (uint32_t i = 0; i < pass.variant_count && index.fast; ++i) {
    const kiln::runtime::Variant& variant = ix.variants[pass.first_variant + i];
    uint32_t chosen[kMaxFastGroups];
    std::fill_n(chosen, groups, kNoValue);
    // A variant select never returns is left out: one with a keyword no group declares, two keywords that belong to
    // one group (the first group that declares a keyword takes it), or none for a group without an off value.
    bool reachable = true;
    for (uint32_t k = 0; k < variant.keyword_count; ++k) {
      const PassIndex::KeywordPlace* at = index.place_of(ix.variant_keywords[variant.first_keyword + k]);
      if (!at || chosen[at->group] != kNoValue) {
        reachable = false;
        break;
      }
      chosen[at->group] = at->value;
    }
    uint64_t code = 0;
    for (size_t g = 0; g < groups && reachable; ++g) {
      if (chosen[g] == kNoValue) chosen[g] = index.off_value[g];
      if (chosen[g] == kNoValue) reachable = false;
      else code += chosen[g] * index.radix[g];
    }
    if (reachable) codes.emplace_back(code, i);
  }
  // PackReader keeps the last of variants with equal keywords; so does a stable sort and a unique from the back.
  std::stable_sort(codes.begin(), codes.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  for (size_t i = 0; i < codes.size(); ++i)
    if (i + 1 == codes.size() || codes[i + 1].first != codes[i].first) index.by_code.push_back(codes[i]);
}

// The fast path of kiln_select; false when the call must go through PackReader::select (an error, or a pass the
// table cannot encode). No allocation, no string: this is what a game calls per draw.
bool select_fast(const PassIndex& index, const kiln_keyword* keywords, size_t count, bool strict, uint32_t* variant) {
  if (!index.fast) return false;
  const size_t groups = index.off_value.size();
  uint32_t chosen[kMaxFastGroups];
  std::fill_n(chosen, groups, kNoValue);
  for (size_t k = 0; k < count; ++k) {
    const PassIndex::KeywordPlace* place = index.place_of(keywords[k]);
    if (!place) {
      if (strict) return false;
      continue;
    }
    if (chosen[place->group] != kNoValue && chosen[place->group] != place->value) return false;
    chosen[place->group] = place->value;
  }
  uint64_t code = 0;
  for (size_t g = 0; g < groups; ++g) {
    uint32_t value = chosen[g];
    if (value == kNoValue) value = index.off_value[g];
    if (value == kNoValue) {
      if (index.one_value[g] == 0) return false;
      value = 0;  // a one-keyword multi_compile is always on
    }
    code += value * index.radix[g];
  }
  auto it = std::lower_bound(index.by_code.begin(), index.by_code.end(), std::pair<uint64_t, uint32_t>(code, 0),
                             [](const auto& a, const auto& b) { return a.first < b.first; });
  if (it == index.by_code.end() || it->first != code) return false;
  *variant = it->second;
  return true;
}

kiln_scalar scalar_of(const std::string& type, uint32_t* components) {
  static constexpr std::pair<const char*, kiln_scalar> kScalars[] = {
      {"float", KILN_SCALAR_FLOAT}, {"half", KILN_SCALAR_HALF}, {"int", KILN_SCALAR_INT},
      {"uint", KILN_SCALAR_UINT},   {"bool", KILN_SCALAR_BOOL}};
  *components = 0;
  for (const auto& [name, scalar] : kScalars) {
    const size_t n = std::strlen(name);
    if (type.compare(0, n, name) != 0) continue;
    if (type.size() == n) { *components = 1; return scalar; }
    if (type.size() == n + 1 && type[n] >= '1' && type[n] <= '4') { *components = static_cast<uint32_t>(type[n] - '0'); return scalar; }
  }
  return KILN_SCALAR_UNKNOWN;
}

kiln_stage_variable variable_of(const kiln::StageVariable& v) {
  kiln_stage_variable out{};
  out.name = v.name.c_str();
  out.location = v.location;
  out.type = v.type.c_str();
  out.scalar = scalar_of(v.type, &out.components);
  out.semantic = v.semantic.c_str();
  return out;
}

template <class T>
uint32_t count_of(const std::vector<T>& records) { return static_cast<uint32_t>(records.size()); }

// A handle's record: decoded before kiln_variant_reflection hands the handle out.
const kiln::Reflection& of(const kiln_reflection* r) { return *r->reflection.load(std::memory_order_acquire); }

const kiln::GlBindings* gl_of(const kiln_reflection* r, int es) { return r ? of(r).gl(es != 0) : nullptr; }

// The tables of the pack version the reader serves now (kiln_pack_open, and kiln_pack_poll_update after a switch):
// built in place, after the reader has its final address, as they point into its index.
void index_tables(kiln_pack& pack) {
  const kiln::runtime::Index& index = pack.reader.index();
  pack.index = &index;
  pack.binaries = std::make_unique<kiln_reflection[]>(index.binaries.size());
  for (size_t b = 0; b < index.binaries.size(); ++b) {
    kiln_reflection& r = pack.binaries[b];
    r.id = index.binaries[b].reflection;
    r.stage = static_cast<kiln_stage>(index.binaries[b].stage);
    r.stage_flags = stage_flag(r.stage);
  }
  pack.passes.clear();
  pack.passes.resize(index.passes.size());
  for (size_t p = 0; p < index.passes.size(); ++p) {
    pack.passes[p].pass = &index.passes[p];
    index_pass(index, pack.passes[p]);
  }
}

}  // namespace

extern "C" {

const char* kiln_result_name(kiln_result code) {
  switch (code) {
    case KILN_OK: return "ok";
    case KILN_ERROR_IO: return "io";
    case KILN_ERROR_FORMAT: return "format";
    case KILN_ERROR_VERSION: return "version";
    case KILN_ERROR_CHECKSUM: return "checksum";
    case KILN_ERROR_UNKNOWN_PASS: return "unknown pass";
    case KILN_ERROR_UNKNOWN_KEYWORD: return "unknown keyword";
    case KILN_ERROR_CONFLICTING_KEYWORDS: return "conflicting keywords";
    case KILN_ERROR_MISSING_KEYWORD: return "missing keyword";
    case KILN_ERROR_STRIPPED: return "stripped";
    case KILN_ERROR_OUT_OF_MEMORY: return "out of memory";
    case KILN_ERROR_INVALID_ARGUMENT: return "invalid argument";
  }
  return "unknown error code";
}

kiln_result kiln_pack_open(const char* path, kiln_pack** pack, kiln_error* error) {
  if (!pack) return invalid(error, "kiln_pack_open: pack is NULL");
  *pack = nullptr;
  if (!path) return invalid(error, "kiln_pack_open: path is NULL");
  return guarded(error, [&] {
    auto* opened = new kiln_pack{kiln::PackReader::open(path), nullptr, {}, {}};
    std::unique_ptr<kiln_pack> owner(opened);
    index_tables(*opened);
    *pack = owner.release();
    return ok(error);
  });
}

void kiln_pack_close(kiln_pack* pack) { delete pack; }

kiln_result kiln_pack_record_usage(kiln_pack* pack, const char* path, const char* const* tags, size_t tag_count,
                                   kiln_error* error) {
  if (!pack || !path || (tag_count > 0 && !tags)) return invalid(error, "kiln_pack_record_usage: a NULL argument");
  return guarded(error, [&] {
    kiln::PackReader::UsageOptions options;
    options.file = path;
    for (size_t t = 0; t < tag_count; ++t) {
      const char* equals = tags[t] ? std::strchr(tags[t], '=') : nullptr;
      if (!equals || equals == tags[t]) return invalid(error, "kiln_pack_record_usage: tag %zu is not \"key=value\"", t);
      options.tags.emplace_back(std::string(tags[t], equals), std::string(equals + 1));
    }
    pack->reader.record_usage(std::move(options));
    return ok(error);
  });
}

kiln_result kiln_pack_flush_usage(const kiln_pack* pack, kiln_error* error) {
  if (!pack) return invalid(error, "kiln_pack_flush_usage: a NULL argument");
  auto written = pack->reader.flush_usage();
  if (!written) return fail(error, code_of(written.code()), written.message().c_str(), written.file().c_str());
  return ok(error);
}

const char* kiln_pack_name(const kiln_pack* pack) { return pack ? pack->reader.name().c_str() : nullptr; }

uint32_t kiln_pass_count(const kiln_pack* pack) { return pack ? count_of(pack->passes) : 0; }

const char* kiln_pass_name(const kiln_pack* pack, kiln_pass pass) {
  return pack && pass < pack->passes.size() ? pack->passes[pass].pass->name.data() : nullptr;
}

kiln_result kiln_pass_find(const kiln_pack* pack, const char* name, kiln_pass* pass, kiln_error* error) {
  if (!pack || !name || !pass) return invalid(error, "kiln_pass_find: a NULL argument");
  for (size_t p = 0; p < pack->passes.size(); ++p)
    if (pack->passes[p].pass->name == name) {
      *pass = static_cast<kiln_pass>(p);
      return ok(error);
    }
  // The C++ reader's own error and message.
  return guarded(error, [&] {
    pack->reader.variant_count(name);
    return fail(error, KILN_ERROR_UNKNOWN_PASS, "unknown pass");
  });
}

uint32_t kiln_keyword_count(const kiln_pack* pack) { return pack ? pack->index->declared_keywords : 0; }

const char* kiln_keyword_name(const kiln_pack* pack, kiln_keyword keyword) {
  return pack && keyword < pack->index->declared_keywords ? pack->index->keywords[keyword].data() : nullptr;
}

kiln_result kiln_keyword_find(const kiln_pack* pack, const char* name, kiln_keyword* keyword, kiln_error* error) {
  if (!pack || !name || !keyword) return invalid(error, "kiln_keyword_find: a NULL argument");
  return guarded(error, [&] {
    const uint32_t id = pack->index->keyword_id(name);
    if (id >= pack->index->declared_keywords)
      return fail(error, KILN_ERROR_UNKNOWN_KEYWORD,
                  ("pack '" + pack->reader.name() + "' has no pass that declares keyword '" + name + "'").c_str());
    *keyword = id;
    return ok(error);
  });
}

uint32_t kiln_pass_group_count(const kiln_pack* pack, kiln_pass pass) {
  return pack && pass < pack->passes.size() ? pack->passes[pass].pass->group_count : 0;
}

uint32_t kiln_pass_group_value_count(const kiln_pack* pack, kiln_pass pass, uint32_t group) {
  if (group >= kiln_pass_group_count(pack, pass)) return 0;
  return pack->index->groups[pack->passes[pass].pass->first_group + group].value_count;
}

const char* kiln_pass_group_value(const kiln_pack* pack, kiln_pass pass, uint32_t group, uint32_t value) {
  if (value >= kiln_pass_group_value_count(pack, pass, group)) return nullptr;
  const uint32_t id = pack->index->values[pack->index->groups[pack->passes[pass].pass->first_group + group].first_value + value];
  return id == kiln::runtime::kOffValue ? "" : pack->index->keywords[id].data();
}

kiln_result kiln_select(const kiln_pack* pack, kiln_pass pass, const kiln_keyword* keywords, size_t count, int strict,
                        uint32_t* variant, kiln_error* error) {
  if (!pack || !variant || (count > 0 && !keywords)) return invalid(error, "kiln_select: a NULL argument");
  if (pass >= pack->passes.size())
    return invalid(error, "kiln_select: pass %u out of range (the pack has %zu)", pass, pack->passes.size());
  for (size_t k = 0; k < count; ++k)
    if (keywords[k] >= pack->index->declared_keywords)
      return invalid(error, "kiln_select: keyword %u out of range (the pack has %u)", keywords[k], pack->index->declared_keywords);
  if (select_fast(pack->passes[pass], keywords, count, strict != 0, variant)) {
    pack->reader.note_selected(pass, *variant);
    return ok(error);
  }
  return guarded(error, [&] {
    std::vector<std::string> names;
    for (size_t k = 0; k < count; ++k) names.emplace_back(pack->index->keywords[keywords[k]]);
    *variant = static_cast<uint32_t>(pack->reader.select(pack->passes[pass].pass->name, names, strict != 0).index);
    return ok(error);
  });
}

kiln_result kiln_select_by_names(const kiln_pack* pack, const char* pass, const char* const* keywords, size_t count,
                                 int strict, uint32_t* variant, kiln_error* error) {
  if (!pack || !pass || !variant || (count > 0 && !keywords)) return invalid(error, "kiln_select_by_names: a NULL argument");
  for (size_t k = 0; k < count; ++k)
    if (!keywords[k]) return invalid(error, "kiln_select_by_names: keyword %zu is NULL", k);
  return guarded(error, [&] {
    std::vector<std::string> names(keywords, keywords + count);
    *variant = static_cast<uint32_t>(pack->reader.select(pass, names, strict != 0).index);
    return ok(error);
  });
}

uint32_t kiln_variant_count(const kiln_pack* pack, kiln_pass pass) {
  return pack && pass < pack->passes.size() ? pack->passes[pass].pass->variant_count : 0;
}

uint32_t kiln_variant_keyword_count(const kiln_pack* pack, kiln_pass pass, uint32_t variant) {
  const kiln::runtime::Variant* v = find_variant(pack, pass, variant);
  return v ? v->keyword_count : 0;
}

const char* kiln_variant_keyword(const kiln_pack* pack, kiln_pass pass, uint32_t variant, uint32_t index) {
  const kiln::runtime::Variant* v = find_variant(pack, pass, variant);
  return v && index < v->keyword_count ? pack->index->keywords[pack->index->variant_keywords[v->first_keyword + index]].data() : nullptr;
}

uint32_t kiln_pass_value_count(const kiln_pack* pack, kiln_pass pass) {
  return pack && pass < pack->index->passes.size() ? pack->index->passes[pass].folded_count : 0;
}

namespace {

kiln_keyword_value keyword_value(const kiln_pack* pack, const kiln::runtime::Folded& folded, bool on) {
  uint32_t flags = 0;
  for (kiln::Stage s : kiln::kAllStages)
    if (folded.stages & kiln::stage_bit(s)) flags |= stage_flag(static_cast<kiln_stage>(s));
  return kiln_keyword_value{folded.keyword == kiln::runtime::kOffValue ? "" : pack->index->keywords[folded.keyword].data(),
                            static_cast<kiln_keyword_kind>(folded.kind), flags, folded.slot, on ? 1u : 0u,
                            on ? folded.value : folded.fallback};
}

}  // namespace

kiln_result kiln_variant_value(const kiln_pack* pack, kiln_pass pass, uint32_t variant, uint32_t index,
                               kiln_keyword_value* value, kiln_error* error) {
  if (!value) return invalid(error, "kiln_variant_value: value is NULL");
  const kiln::runtime::Variant* v = find_variant(pack, pass, variant);
  if (!v) return invalid(error, "kiln_variant_value: no variant %u of pass %u", variant, pass);
  const kiln::runtime::Pass& p = pack->index->passes[pass];
  if (index >= p.folded_count) return invalid(error, "kiln_variant_value: pass %u has %u folded keywords, not %u", pass, p.folded_count, index + 1);
  return guarded(error, [&] {  // folded_on allocates: OUT_OF_MEMORY, never an exception through C
    *value = keyword_value(pack, pack->index->folded[p.first_folded + index], pack->index->folded_on(p, *v)[index]);
    return ok(error);
  });
}

kiln_result kiln_variant_values(const kiln_pack* pack, kiln_pass pass, uint32_t variant, kiln_keyword_value* values,
                                uint32_t capacity, kiln_error* error) {
  const kiln::runtime::Variant* v = find_variant(pack, pass, variant);
  if (!v) return invalid(error, "kiln_variant_values: no variant %u of pass %u", variant, pass);
  const kiln::runtime::Pass& p = pack->index->passes[pass];
  if (capacity < p.folded_count)
    return invalid(error, "kiln_variant_values: pass %u has %u folded keywords, room for %u", pass, p.folded_count, capacity);
  if (p.folded_count > 0 && !values) return invalid(error, "kiln_variant_values: values is NULL");
  return guarded(error, [&] {  // one folded_on for them all: a value at a time is that cost per value
    const std::vector<bool> on = pack->index->folded_on(p, *v);
    for (uint32_t f = 0; f < p.folded_count; ++f) values[f] = keyword_value(pack, pack->index->folded[p.first_folded + f], on[f]);
    return ok(error);
  });
}

kiln_result kiln_variant_code(const kiln_pack* pack, kiln_pass pass, uint32_t variant, kiln_stage stage,
                              kiln_target target, kiln_code* code, kiln_error* error) {
  if (!code) return invalid(error, "kiln_variant_code: code is NULL");
  *code = kiln_code{nullptr, 0};
  if (!find_variant(pack, pass, variant)) return invalid(error, "kiln_variant_code: no variant %u of pass %u", variant, pass);
  if (static_cast<int>(stage) < 0 || static_cast<int>(stage) >= kiln::kStageCount) return invalid(error, "kiln_variant_code: stage %d", static_cast<int>(stage));
  if (static_cast<int>(target) < 0 || static_cast<int>(target) >= kiln::kTargetCount) return invalid(error, "kiln_variant_code: target %d", static_cast<int>(target));
  const uint32_t binary = find_binary(pack, pass, variant, stage);
  if (binary == kiln::runtime::kNone) return ok(error);
  const uint32_t blob = pack->index->binaries[binary].blobs[static_cast<size_t>(target)];
  if (blob == kiln::runtime::kNone) return ok(error);
  return guarded(error, [&] {
    std::string_view bytes = pack->reader.blob(blob);
    *code = kiln_code{bytes.data(), bytes.size()};
    return ok(error);
  });
}

const char* kiln_variant_entry_point(const kiln_pack* pack, kiln_pass pass, uint32_t variant, kiln_stage stage) {
  const uint32_t binary = find_binary(pack, pass, variant, stage);
  return binary == kiln::runtime::kNone ? nullptr : pack->index->binaries[binary].entry.data();
}

const kiln_reflection* kiln_variant_reflection(const kiln_pack* pack, kiln_pass pass, uint32_t variant, kiln_stage stage) {
  const uint32_t binary = find_binary(pack, pass, variant, stage);
  if (binary == kiln::runtime::kNone) return nullptr;
  kiln_reflection& r = pack->binaries[binary];
  if (!r.reflection.load(std::memory_order_acquire)) {
    // Decoded on first use; a record that does not decode (or no memory for it) gives no handle.
    try {
      r.reflection.store(&pack->reader.reflection(r.id), std::memory_order_release);
    } catch (...) {
      return nullptr;
    }
  }
  return &r;
}

kiln_stage kiln_reflection_stage(const kiln_reflection* reflection) { return reflection ? reflection->stage : KILN_STAGE_VERTEX; }

int kiln_reflection_local_size(const kiln_reflection* reflection, uint32_t size[3]) {
  if (!reflection || !size || !of(reflection).local_size) return 0;
  for (int i = 0; i < 3; ++i) size[i] = (*of(reflection).local_size)[i];
  return 1;
}

uint32_t kiln_reflection_resource_count(const kiln_reflection* r) { return r ? count_of(of(r).resources) : 0; }

int kiln_reflection_resource(const kiln_reflection* r, uint32_t index, kiln_resource* out) {
  if (!out || index >= kiln_reflection_resource_count(r)) return 0;
  const kiln::Resource& resource = of(r).resources[index];
  *out = kiln_resource{};
  out->name = resource.name.c_str();
  out->kind = static_cast<kiln_resource_kind>(resource.kind);
  out->set = resource.set;
  out->binding = resource.binding;
  out->count = resource.count;
  out->stage_flags = r->stage_flags;
  out->size = resource.size;
  out->dimension = resource.dimension.c_str();
  out->depth = resource.depth ? 1 : 0;
  out->input_attachment_index = resource.input_attachment_index;
  return 1;
}

uint32_t kiln_reflection_push_constant_count(const kiln_reflection* r) { return r ? count_of(of(r).push_constants) : 0; }

int kiln_reflection_push_constant(const kiln_reflection* r, uint32_t index, kiln_push_constant* out) {
  if (!out || index >= kiln_reflection_push_constant_count(r)) return 0;
  const kiln::PushConstantBlock& block = of(r).push_constants[index];
  *out = kiln_push_constant{block.name.c_str(), block.size, r->stage_flags};
  return 1;
}

uint32_t kiln_reflection_input_count(const kiln_reflection* r) { return r ? count_of(of(r).inputs) : 0; }

int kiln_reflection_input(const kiln_reflection* r, uint32_t index, kiln_stage_variable* out) {
  if (!out || index >= kiln_reflection_input_count(r)) return 0;
  *out = variable_of(of(r).inputs[index]);
  return 1;
}

uint32_t kiln_reflection_output_count(const kiln_reflection* r) { return r ? count_of(of(r).outputs) : 0; }

int kiln_reflection_output(const kiln_reflection* r, uint32_t index, kiln_stage_variable* out) {
  if (!out || index >= kiln_reflection_output_count(r)) return 0;
  *out = variable_of(of(r).outputs[index]);
  return 1;
}

uint32_t kiln_reflection_gl_sampler_count(const kiln_reflection* r, int es) {
  const kiln::GlBindings* gl = gl_of(r, es);
  return gl ? count_of(gl->combined_image_samplers) : 0;
}

int kiln_reflection_gl_sampler(const kiln_reflection* r, int es, uint32_t index, kiln_gl_sampler* out) {
  if (!out || index >= kiln_reflection_gl_sampler_count(r, es)) return 0;
  const kiln::GlCombinedSampler& s = gl_of(r, es)->combined_image_samplers[index];
  *out = kiln_gl_sampler{s.name.c_str(), s.texture.c_str(), s.sampler.c_str(), s.binding};
  return 1;
}

uint32_t kiln_reflection_gl_block_count(const kiln_reflection* r, int es) {
  const kiln::GlBindings* gl = gl_of(r, es);
  return gl ? count_of(gl->blocks) : 0;
}

int kiln_reflection_gl_block(const kiln_reflection* r, int es, uint32_t index, kiln_gl_block* out) {
  if (!out || index >= kiln_reflection_gl_block_count(r, es)) return 0;
  const kiln::GlBlock& b = gl_of(r, es)->blocks[index];
  *out = kiln_gl_block{b.name.c_str(), static_cast<kiln_resource_kind>(b.kind), b.binding};
  return 1;
}

uint32_t kiln_reflection_msl_resource_count(const kiln_reflection* r) {
  return r && of(r).msl ? count_of(of(r).msl->resources) : 0;
}

int kiln_reflection_msl_resource(const kiln_reflection* r, uint32_t index, kiln_msl_resource* out) {
  if (!out || index >= kiln_reflection_msl_resource_count(r)) return 0;
  const kiln::MslResource& m = of(r).msl->resources[index];
  *out = kiln_msl_resource{m.name.c_str(), static_cast<kiln_msl_kind>(m.kind), m.index};
  return 1;
}

// ---- Live updates: kiln_pack_poll_update and kiln_pack_update_fd (kiln_reader.h) ----------------------------------

}  // extern "C"

// What kiln_pack_poll_update keeps: the tables of the version it switched away from (the pointers handed out before
// the switch point into them, and into the version the C++ reader keeps as long) until its next call, and the last
// update's records, which the kiln_pack_update it filled points into.
struct PackUpdates {
  const kiln::runtime::Index* previous_index = nullptr;
  std::vector<PassIndex> previous_passes;
  std::unique_ptr<kiln_reflection[]> previous_binaries;
  kiln::PackUpdate update;
  std::vector<kiln_variant_change> changes;
  std::vector<std::vector<const char*>> keywords;  // per change
};

extern "C" {

kiln_result kiln_pack_poll_update(kiln_pack* pack, kiln_pack_update* update, kiln_error* error) {
  if (update) *update = kiln_pack_update{};
  if (!pack || !update) return invalid(error, "kiln_pack_poll_update: a NULL argument");
  return guarded(error, [&] {
    if (!pack->updates) pack->updates = std::make_shared<PackUpdates>();
    PackUpdates& u = *pack->updates;
    // What this call's previous switch kept is done with: the caller polls again.
    u.previous_index = nullptr;
    u.previous_passes.clear();
    u.previous_binaries.reset();
    u.changes.clear();
    u.keywords.clear();
    u.update = {};
    auto polled = pack->reader.poll_update();
    if (!polled) return fail(error, code_of(polled.code()), polled.message().c_str(), polled.file().c_str());
    u.update = std::move(*polled);
    if (u.update.switched) {
      u.previous_index = pack->index;
      u.previous_passes = std::move(pack->passes);
      u.previous_binaries = std::move(pack->binaries);
      index_tables(*pack);
      auto pass_id = [](const std::vector<PassIndex>& passes, const std::string& name) {
        for (size_t p = 0; p < passes.size(); ++p)
          if (passes[p].pass->name == name) return static_cast<uint32_t>(p);
        return static_cast<uint32_t>(KILN_NO_INDEX);
      };
      auto index_of = [](size_t index) {
        return index == kiln::VariantChange::kNoIndex ? static_cast<uint32_t>(KILN_NO_INDEX) : static_cast<uint32_t>(index);
      };
      u.keywords.reserve(u.update.changes.size());
      for (const kiln::VariantChange& change : u.update.changes) {
        std::vector<const char*>& names = u.keywords.emplace_back();
        for (const std::string& keyword : change.keywords) names.push_back(keyword.c_str());
        kiln_variant_change c{};
        c.kind = static_cast<kiln_variant_change_kind>(static_cast<int>(change.kind) + 1);
        c.pass = change.pass.c_str();
        c.old_pass = pass_id(u.previous_passes, change.pass);
        c.new_pass = pass_id(pack->passes, change.pass);
        c.old_variant = index_of(change.old_index);
        c.new_variant = index_of(change.new_index);
        c.keywords = names.empty() ? nullptr : names.data();
        c.keyword_count = static_cast<uint32_t>(names.size());
        u.changes.push_back(c);
      }
    }
    update->switched = u.update.switched ? 1 : 0;
    update->ids_changed = u.update.ids_changed ? 1 : 0;
    update->version = u.update.version;
    update->archive = u.update.archive.c_str();
    update->changes = u.changes.empty() ? nullptr : u.changes.data();
    update->change_count = u.changes.size();
    return ok(error);
  });
}

kiln_result kiln_pack_update_fd(kiln_pack* pack, int* fd, kiln_error* error) {
  if (!pack || !fd) return invalid(error, "kiln_pack_update_fd: a NULL argument");
  auto got = pack->reader.update_fd();
  if (!got) return fail(error, code_of(got.code()), got.message().c_str(), got.file().c_str());
  *fd = *got;
  return ok(error);
}

}  // extern "C"

// kiln_variant_change_kind is VariantChange::Kind plus one, value for value: the cast above relies on it.
static_assert(KILN_VARIANT_ADDED == static_cast<int>(kiln::VariantChange::Kind::Added) + 1 &&
              KILN_VARIANT_CHANGED == static_cast<int>(kiln::VariantChange::Kind::Changed) + 1 &&
              KILN_VARIANT_REMOVED == static_cast<int>(kiln::VariantChange::Kind::Removed) + 1 &&
              KILN_VARIANT_MOVED == static_cast<int>(kiln::VariantChange::Kind::Moved) + 1);

// The C enumerations are the C++ ones, value for value: the casts above rely on it.
static_assert(KILN_STAGE_VERTEX == static_cast<int>(kiln::Stage::Vertex) && KILN_STAGE_FRAGMENT == static_cast<int>(kiln::Stage::Fragment) &&
              KILN_STAGE_COMPUTE == static_cast<int>(kiln::Stage::Compute) && KILN_STAGE_GEOMETRY == static_cast<int>(kiln::Stage::Geometry) &&
              KILN_STAGE_HULL == static_cast<int>(kiln::Stage::Hull) && KILN_STAGE_DOMAIN == static_cast<int>(kiln::Stage::Domain));
#define KILN_TARGET(Enumerator, id, extension, other_extensions, C_NAME, emit, library, description) \
  static_assert(KILN_TARGET_##C_NAME == static_cast<int>(kiln::Target::Enumerator));
#include "kiln/targets.def"
static_assert(KILN_TARGET_COUNT == kiln::kTargetCount);
static_assert(KILN_RESOURCE_UNIFORM_BUFFER == static_cast<int>(kiln::ResourceKind::UniformBuffer) &&
              KILN_RESOURCE_STORAGE_BUFFER == static_cast<int>(kiln::ResourceKind::StorageBuffer) &&
              KILN_RESOURCE_TEXTURE == static_cast<int>(kiln::ResourceKind::Texture) &&
              KILN_RESOURCE_SAMPLER == static_cast<int>(kiln::ResourceKind::Sampler) &&
              KILN_RESOURCE_COMBINED_IMAGE_SAMPLER == static_cast<int>(kiln::ResourceKind::CombinedImageSampler) &&
              KILN_RESOURCE_STORAGE_IMAGE == static_cast<int>(kiln::ResourceKind::StorageImage) &&
              KILN_RESOURCE_UNIFORM_TEXEL_BUFFER == static_cast<int>(kiln::ResourceKind::UniformTexelBuffer) &&
              KILN_RESOURCE_STORAGE_TEXEL_BUFFER == static_cast<int>(kiln::ResourceKind::StorageTexelBuffer) &&
              KILN_RESOURCE_INPUT_ATTACHMENT == static_cast<int>(kiln::ResourceKind::InputAttachment));
static_assert(KILN_MSL_BUFFER == static_cast<int>(kiln::MslResourceKind::Buffer) &&
              KILN_MSL_TEXTURE == static_cast<int>(kiln::MslResourceKind::Texture) &&
              KILN_MSL_SAMPLER == static_cast<int>(kiln::MslResourceKind::Sampler));
// Each folded kind's kiln_keyword_kind is its KeywordKind (kiln/keyword_kinds.def).
#define KILN_KEYWORD_KIND(kind, name, folded, constant, c_constant, what) \
  static_assert(!(folded) || static_cast<int>(c_constant) == static_cast<int>(kiln::KeywordKind::kind), name);
#include "kiln/keyword_kinds.def"
#undef KILN_KEYWORD_KIND
static_assert(KILN_KEYWORD_BLOCK_SET == kiln::kKeywordBlockSet && KILN_KEYWORD_BLOCK_BINDING == kiln::kKeywordBlockBinding);
