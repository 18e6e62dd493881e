// SPDX-License-Identifier: Apache-2.0
#include "kiln/runtime_index.hpp"

#include <algorithm>
#include <cstring>
#include <map>
#include <optional>
#include <set>

#include "kiln/pack_format.hpp"

namespace kiln::runtime {
namespace {

// ---- Bytes ------------------------------------------------------------------------------------------------------

class Writer {
 public:
  std::string bytes;
  void u8(uint8_t v) { bytes.push_back(static_cast<char>(v)); }
  void u32(uint32_t v) {
    for (int i = 0; i < 4; ++i) bytes.push_back(static_cast<char>(v >> (8 * i)));
  }
  void u64(uint64_t v) {
    for (int i = 0; i < 8; ++i) bytes.push_back(static_cast<char>(v >> (8 * i)));
  }
  void str(std::string_view s) {
    u32(static_cast<uint32_t>(s.size()));
    bytes += s;
    bytes.push_back('\0');
  }
  void count(size_t n) { u32(static_cast<uint32_t>(n)); }
};

class Reader {
 public:
  Reader(std::string_view bytes, const char* what) : bytes_(bytes), what_(what) {}
  [[noreturn]] void fail(const std::string& message) const {
    throw IndexError(std::string(what_) + " at byte " + std::to_string(at_) + ": " + message);
  }
  void need(uint64_t n) const {
    if (n > bytes_.size() - at_) fail("ends early (needs " + std::to_string(n) + " more bytes)");
  }
  uint8_t u8() {
    need(1);
    return static_cast<uint8_t>(bytes_[at_++]);
  }
  uint32_t u32() {
    need(4);
    uint32_t v = 0;
    for (int i = 0; i < 4; ++i) v |= static_cast<uint32_t>(static_cast<unsigned char>(bytes_[at_ + i])) << (8 * i);
    at_ += 4;
    return v;
  }
  uint64_t u64() {
    need(8);
    uint64_t v = 0;
    for (int i = 0; i < 8; ++i) v |= static_cast<uint64_t>(static_cast<unsigned char>(bytes_[at_ + i])) << (8 * i);
    at_ += 8;
    return v;
  }
  std::string_view str() {
    const uint32_t n = u32();
    need(uint64_t{n} + 1);
    std::string_view s = bytes_.substr(at_, n);
    if (bytes_[at_ + n] != '\0' || s.find('\0') != std::string_view::npos) fail("a string is not NUL-terminated text");
    at_ += n + 1;
    return s;
  }
  std::string_view bytes(uint64_t n) {
    need(n);
    std::string_view v = bytes_.substr(at_, n);
    at_ += n;
    return v;
  }
  // A count of records each at least `min_bytes` long: larger than the bytes left can hold is refused before
  // anything is allocated for it.
  uint32_t count(uint64_t min_bytes) {
    const uint32_t n = u32();
    if (n * min_bytes > bytes_.size() - at_) fail("a count of " + std::to_string(n) + " records is more than the bytes left hold");
    return n;
  }
  template <class Enum>
  Enum enumerated(size_t values, const char* what) {
    const uint8_t v = u8();
    if (v >= values) fail(std::string("value ") + std::to_string(v) + " is not " + what);
    return static_cast<Enum>(v);
  }
  bool done() const { return at_ == bytes_.size(); }

 private:
  std::string_view bytes_;
  const char* what_;
  size_t at_ = 0;
};

// ---- Reflection: one field list for both directions --------------------------------------------------------------
// `io` is a Writer (the record is const) or a Decoder (it is filled); each type's fields are listed once.

struct Decoder {
  Reader& in;
  void field(std::string& s) { s = std::string(in.str()); }
  void field(uint32_t& v) { v = in.u32(); }
  void field(uint64_t& v) { v = in.u64(); }
  void field(bool& v) {
    const uint8_t b = in.u8();
    if (b > 1) in.fail("a flag is not 0 or 1");
    v = b != 0;
  }
  void field(ResourceKind& v) {
    v = in.enumerated<ResourceKind>(static_cast<size_t>(ResourceKind::InputAttachment) + 1, "a resource kind");
  }
  void field(MslResourceKind& v) { v = in.enumerated<MslResourceKind>(3, "an MSL resource kind"); }
  template <class... T>
  void fields(T&... v) {
    (field(v), ...);
  }
  template <class T, class F>
  void list(std::vector<T>& v, F&& each) {
    v.resize(in.count(4));
    for (T& e : v) each(e);
  }
  template <class T, class F>
  void optional(std::optional<T>& v, F&& each) {
    bool present = false;
    field(present);
    if (present) each(v.emplace());
  }
};

struct Encoder {
  Writer& out;
  void field(const std::string& s) { out.str(s); }
  void field(uint32_t v) { out.u32(v); }
  void field(uint64_t v) { out.u64(v); }
  void field(bool v) { out.u8(v ? 1 : 0); }
  void field(ResourceKind v) { out.u8(static_cast<uint8_t>(v)); }
  void field(MslResourceKind v) { out.u8(static_cast<uint8_t>(v)); }
  template <class... T>
  void fields(const T&... v) {
    (field(v), ...);
  }
  template <class T, class F>
  void list(const std::vector<T>& v, F&& each) {
    out.count(v.size());
    for (const T& e : v) each(e);
  }
  template <class T, class F>
  void optional(const std::optional<T>& v, F&& each) {
    field(v.has_value());
    if (v) each(*v);
  }
};

template <class IO, class M>
void members(IO& io, M& list) {
  io.list(list, [&](auto& m) {
    io.fields(m.name, m.offset, m.size, m.type);
    io.optional(m.array_stride, [&](auto& stride) { io.field(stride); });
  });
}

template <class IO, class G>
void gl_bindings(IO& io, G& gl) {
  io.list(gl.combined_image_samplers, [&](auto& s) { io.fields(s.name, s.texture, s.sampler, s.binding); });
  io.list(gl.blocks, [&](auto& b) { io.fields(b.name, b.kind, b.binding); });
}

template <class IO, class R>
void reflection_fields(IO& io, R& r) {
  io.list(r.resources, [&](auto& res) {
    io.fields(res.name, res.kind, res.set, res.binding, res.count, res.size);
    members(io, res.members);
    io.fields(res.dimension, res.depth);
    // Only an input attachment carries its index: a record of any other kind has the bytes it had before the kind
    // existed, so packs without input attachments are unchanged (a reader without the kind refuses the record).
    if (res.kind == ResourceKind::InputAttachment) io.field(res.input_attachment_index);
  });
  io.list(r.push_constants, [&](auto& block) {
    io.fields(block.name, block.size);
    members(io, block.members);
  });
  io.list(r.inputs, [&](auto& v) { io.fields(v.name, v.location, v.type, v.semantic); });
  io.list(r.outputs, [&](auto& v) { io.fields(v.name, v.location, v.type, v.semantic); });
  io.optional(r.local_size, [&](auto& size) { io.fields(size[0], size[1], size[2]); });
  io.optional(r.glsl, [&](auto& gl) { gl_bindings(io, gl); });
  io.optional(r.gles, [&](auto& gl) { gl_bindings(io, gl); });
  io.optional(r.msl, [&](auto& msl) { io.list(msl.resources, [&](auto& m) { io.fields(m.name, m.kind, m.index); }); });
}

}  // namespace

std::string encode_reflection(const Reflection& reflection) {
  Writer out;
  Encoder io{out};
  reflection_fields(io, reflection);
  return std::move(out.bytes);
}

Reflection decode_reflection(std::string_view bytes) {
  Reader in(bytes, "a reflection record");
  Decoder io{in};
  Reflection r;
  reflection_fields(io, r);
  if (!in.done()) in.fail("has bytes after its end");
  if (r.local_size && std::find(r.local_size->begin(), r.local_size->end(), 0u) != r.local_size->end())
    in.fail("has a thread-group size of 0");
  for (const GlBindings* gl : {r.gl(false), r.gl(true)})
    if (gl)
      for (const GlBlock& block : gl->blocks)
        if (!is_block(block.kind)) in.fail("a GL block's kind is not a block kind");
  return r;
}

// ---- The index ----------------------------------------------------------------------------------------------------

std::string encode(const Manifest& manifest) {
  std::vector<std::string> declared, undeclared;
  for (const ManifestPass& pass : manifest.passes)
    for (const ManifestKeywordGroup& group : pass.keyword_groups)
      for (const std::string& value : group.values)
        if (!value.empty()) declared.push_back(value);
  std::sort(declared.begin(), declared.end());
  declared.erase(std::unique(declared.begin(), declared.end()), declared.end());
  for (const ManifestPass& pass : manifest.passes)
    for (const ManifestVariant& variant : pass.variants)
      for (const std::string& keyword : variant.keywords)
        if (!std::binary_search(declared.begin(), declared.end(), keyword)) undeclared.push_back(keyword);
  std::sort(undeclared.begin(), undeclared.end());
  undeclared.erase(std::unique(undeclared.begin(), undeclared.end()), undeclared.end());
  auto id_of = [&](const std::string& keyword) {
    auto it = std::lower_bound(declared.begin(), declared.end(), keyword);
    if (it != declared.end() && *it == keyword) return static_cast<uint32_t>(it - declared.begin());
    return static_cast<uint32_t>(declared.size() + (std::lower_bound(undeclared.begin(), undeclared.end(), keyword) - undeclared.begin()));
  };

  Writer out;
  for (const auto* table : {&declared, &undeclared}) {
    out.count(table->size());
    for (const std::string& keyword : *table) out.str(keyword);
  }
  out.count(manifest.passes.size());
  for (const ManifestPass& pass : manifest.passes) {
    out.str(pass.name);
    out.count(pass.entry_points.size());
    for (const auto& [stage, entry] : pass.entry_points) {
      out.u8(static_cast<uint8_t>(stage));
      out.str(entry);
    }
    out.count(pass.keyword_groups.size());
    for (const ManifestKeywordGroup& group : pass.keyword_groups) {
      out.str(group.pragma);
      out.u8(group.stages);
      out.count(group.values.size());
      for (const std::string& value : group.values) out.u32(value.empty() ? kOffValue : id_of(value));
    }
    out.count(pass.variants.size());
    for (const ManifestVariant& variant : pass.variants) {
      out.count(variant.keywords.size());
      for (const std::string& keyword : variant.keywords) out.u32(id_of(keyword));
      out.count(variant.binaries.size());
      for (const auto& [stage, binary] : variant.binaries) {
        out.u8(static_cast<uint8_t>(stage));
        out.u32(binary);
      }
    }
  }
  out.count(manifest.binaries.size());
  for (const ManifestBinary& binary : manifest.binaries) {
    out.u8(static_cast<uint8_t>(binary.stage));
    out.str(binary.entry);
    out.count(binary.blobs.size());
    for (const auto& [target, blob] : binary.blobs) {
      out.u8(static_cast<uint8_t>(target));
      out.u32(blob);
    }
    out.u32(binary.reflection);
  }
  out.count(manifest.reflections.size());
  for (const Reflection& reflection : manifest.reflections) {
    const std::string record = encode_reflection(reflection);
    out.count(record.size());
    out.bytes += record;
  }
  return std::move(out.bytes);
}

Index Index::decode(std::string_view bytes, uint64_t blob_count) {
  Reader in(bytes, "the runtime index");
  Index index;
  auto where = [](const char* what, size_t i) { return std::string(what) + " " + std::to_string(i) + ": "; };
  auto strings = [&](const char* what) {
    const uint32_t n = in.count(5);
    for (uint32_t i = 0; i < n; ++i) {
      std::string_view keyword = in.str();
      if (keyword.empty() || (i > 0 && !(index.keywords.back() < keyword)))
        in.fail(std::string(what) + " are not sorted, unique and non-empty");
      index.keywords.push_back(keyword);
    }
  };
  strings("the declared keywords");
  index.declared_keywords = static_cast<uint32_t>(index.keywords.size());
  const size_t first_undeclared = index.keywords.size();
  strings("the undeclared keywords");
  for (size_t i = first_undeclared; i < index.keywords.size(); ++i)
    if (index.keyword_id(index.keywords[i]) != i) in.fail("a keyword is both declared and undeclared");
  const auto keyword_count = static_cast<uint32_t>(index.keywords.size());
  auto stage = [&] { return in.enumerated<Stage>(kStageCount, "a stage"); };

  // Binaries are after the passes: their ids are checked once the binary table's size is known.
  const uint32_t passes = in.count(4 * 4 + 1);
  index.passes.reserve(passes);
  for (uint32_t p = 0; p < passes; ++p) {
    Pass pass;
    pass.name = in.str();
    for (uint32_t n = in.count(6), i = 0; i < n; ++i) {
      const Stage s = stage();
      std::string_view& entry = pass.entry_points[static_cast<size_t>(s)];
      if (!entry.empty()) in.fail(where("pass", p) + "a stage is named twice");
      entry = in.str();
      if (entry.empty()) in.fail(where("pass", p) + "an entry point is empty");
    }
    pass.first_group = static_cast<uint32_t>(index.groups.size());
    pass.group_count = in.count(10);
    for (uint32_t g = 0; g < pass.group_count; ++g) {
      Group group;
      group.pragma = in.str();
      group.stages = in.u8();
      group.first_value = static_cast<uint32_t>(index.values.size());
      group.value_count = in.count(4);
      for (uint32_t v = 0; v < group.value_count; ++v) {
        const uint32_t id = in.u32();
        if (id != kOffValue && id >= index.declared_keywords)
          in.fail(where("pass", p) + "keyword id " + std::to_string(id) + " of a group is not a declared keyword");
        index.values.push_back(id);
      }
      index.groups.push_back(group);
    }
    pass.first_folded = static_cast<uint32_t>(index.folded.size());
    if (std::any_of(index.groups.begin() + pass.first_group, index.groups.end(),
                    [](const Group& g) { return is_folded(keyword_kind(g.pragma)); })) {
      std::vector<ManifestKeywordGroup> records;
      for (uint32_t g = pass.first_group; g < index.groups.size(); ++g) {
        ManifestKeywordGroup& record = records.emplace_back();
        record.pragma = std::string(index.groups[g].pragma);
        record.stages = index.groups[g].stages;
        for (uint32_t v = 0; v < index.groups[g].value_count; ++v) {
          const uint32_t id = index.values[index.groups[g].first_value + v];
          record.values.emplace_back(id == kOffValue ? std::string_view() : index.keywords[id]);
        }
      }
      for (const FoldedKeyword& k : folded_keywords(records))
        index.folded.push_back(Folded{k.keyword.empty() ? kOffValue : index.keyword_id(k.keyword), k.kind, k.stages,
                                      k.slot, k.value, k.fallback});
    }
    pass.folded_count = static_cast<uint32_t>(index.folded.size() - pass.first_folded);
    pass.first_variant = static_cast<uint32_t>(index.variants.size());
    pass.variant_count = in.count(8);
    for (uint32_t v = 0; v < pass.variant_count; ++v) {
      Variant variant;
      variant.binaries.fill(kNone);
      variant.first_keyword = static_cast<uint32_t>(index.variant_keywords.size());
      variant.keyword_count = in.count(4);
      for (uint32_t k = 0; k < variant.keyword_count; ++k) {
        const uint32_t id = in.u32();
        if (id >= keyword_count) in.fail(where("pass", p) + "keyword id " + std::to_string(id) + " is out of range");
        index.variant_keywords.push_back(id);
      }
      for (uint32_t n = in.count(5), i = 0; i < n; ++i) {
        uint32_t& binary = variant.binaries[static_cast<size_t>(stage())];
        if (binary != kNone) in.fail(where("pass", p) + "a variant names a stage twice");
        binary = in.u32();
        if (binary == kNone) in.fail(where("pass", p) + "a binary id is out of range");
      }
      index.variants.push_back(variant);
    }
    index.passes.push_back(pass);
  }
  // Sorted, not compared pair by pair: 150,000 passes (a 3 MB index) took a game's open over a minute.
  std::vector<std::string_view> names;
  names.reserve(index.passes.size());
  for (const Pass& pass : index.passes) names.push_back(pass.name);
  std::sort(names.begin(), names.end());
  if (auto twice = std::adjacent_find(names.begin(), names.end()); twice != names.end())
    in.fail("two passes are named '" + echoed(*twice) + "'");

  const uint32_t binaries = in.count(1 + 5 + 4 + 4);
  index.binaries.reserve(binaries);
  for (uint32_t b = 0; b < binaries; ++b) {
    Binary binary;
    binary.stage = stage();
    binary.entry = in.str();
    binary.blobs.fill(kNone);
    for (uint32_t n = in.count(5), i = 0; i < n; ++i) {
      const Target target = in.enumerated<Target>(kTargetCount, "a target");
      uint32_t& blob = binary.blobs[static_cast<size_t>(target)];
      if (blob != kNone) in.fail(where("binary", b) + "a target is named twice");
      blob = in.u32();
      if (blob >= blob_count)
        in.fail(where("binary", b) + "blob id " + std::to_string(blob) + " is out of range (" + std::to_string(blob_count) + " blobs)");
    }
    binary.reflection = in.u32();
    index.binaries.push_back(binary);
  }
  for (const Variant& variant : index.variants)
    for (uint32_t binary : variant.binaries)
      if (binary != kNone && binary >= binaries)
        in.fail("a variant's binary id " + std::to_string(binary) + " is out of range (" + std::to_string(binaries) + " binaries)");

  const uint32_t reflections = in.count(4);
  index.reflections.reserve(reflections);
  for (uint32_t r = 0; r < reflections; ++r) index.reflections.push_back(in.bytes(in.u32()));
  for (size_t b = 0; b < index.binaries.size(); ++b)
    if (index.binaries[b].reflection >= reflections)
      in.fail(where("binary", b) + "reflection " + std::to_string(index.binaries[b].reflection) + " is out of range (" +
              std::to_string(reflections) + " reflections)");
  if (!in.done()) in.fail("has bytes after its end");
  return index;
}

std::vector<bool> Index::folded_on(const Pass& pass, const Variant& variant) const {
  std::vector<uint32_t> chosen(variant_keywords.begin() + variant.first_keyword,
                               variant_keywords.begin() + variant.first_keyword + variant.keyword_count);
  std::sort(chosen.begin(), chosen.end());
  std::vector<bool> on(pass.folded_count);
  std::set<uint32_t> int_slots_on;  // the constant ids of the int groups one of whose keywords is chosen
  for (uint32_t f = 0; f < pass.folded_count; ++f) {
    const Folded& value = folded[pass.first_folded + f];
    on[f] = value.keyword != kOffValue && std::binary_search(chosen.begin(), chosen.end(), value.keyword);
    if (on[f] && value.kind == KeywordKind::SpecializationInteger) int_slots_on.insert(value.slot);
  }
  for (uint32_t f = 0; f < pass.folded_count; ++f) {
    const Folded& value = folded[pass.first_folded + f];
    if (value.keyword == kOffValue) on[f] = !int_slots_on.contains(value.slot);
  }
  return on;
}

uint32_t Index::keyword_id(std::string_view name) const {
  auto begin = keywords.begin(), end = keywords.begin() + declared_keywords;
  auto it = std::lower_bound(begin, end, name);
  if (it != end && *it == name) return static_cast<uint32_t>(it - keywords.begin());
  auto extra = std::lower_bound(end, keywords.end(), name);
  if (extra != keywords.end() && *extra == name) return static_cast<uint32_t>(extra - keywords.begin());
  return kNone;
}

}  // namespace kiln::runtime
