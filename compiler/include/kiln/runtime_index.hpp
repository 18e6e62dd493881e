// SPDX-License-Identifier: Apache-2.0
// The runtime index: the part of a pack's manifest that a game needs (passes, keyword groups, variants, binaries,
// reflections), as binary records inside the archive (kiln/pack_format.hpp), so that opening a pack parses no text.
// The writer encodes it from the same typed `Manifest` it writes the JSON from; `kiln inspect --verify`
// (PackReader::open with Check::Full) checks that the two agree byte for byte.
//
// Encoding (little-endian; a string is a u32 length, its bytes and a NUL, so the C API hands out pointers into the
// mapped archive; no string holds a NUL):
//   u32 K, K strings        keywords some pass's groups declare, sorted, unique: the C API's keyword ids
//   u32 E, E strings        keywords of variants that no group declares, sorted, unique: ids K..K+E-1
//   u32 P, P passes         name; u32 n, n x {u8 stage, entry point}; u32 groups, each {pragma, u8 stage mask,
//                           u32 n, n x u32 keyword id or kOffValue}; u32 variants, each {u32 n, n keyword ids in the
//                           manifest's (name) order, u32 m, m x {u8 stage, u32 binary}}
//   u32 B, B binaries       u8 stage, entry, u32 n, n x {u8 target, u32 blob id}, u32 reflection
//   u32 R, R reflections    u32 length, the reflection's record (encode_reflection), decoded on first use
// Every count is checked against the bytes left before anything is allocated for it, every id against its table.
//
// Internal to the reader and the pack writer; not installed.
#pragma once

#include <array>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "kiln/folded_keywords.hpp"
#include "kiln/manifest.hpp"

namespace kiln::runtime {

inline constexpr uint32_t kNone = UINT32_MAX;      // no binary for a stage, no blob for a target
inline constexpr uint32_t kOffValue = UINT32_MAX;  // a group's "" value

// A record that does not decode: what and where ("pass 2, variant 7: keyword id 90 is out of range").
class IndexError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct Group {
  std::string_view pragma;
  StageMask stages = kAllStageBits;
  uint32_t first_value = 0, value_count = 0;  // in Index::values
};

struct Variant {
  uint32_t first_keyword = 0, keyword_count = 0;  // in Index::variant_keywords
  std::array<uint32_t, kStageCount> binaries{};   // kNone: the variant has no such stage
};

// A folded keyword of a pass (kiln/folded_keywords.hpp): not encoded, derived from the pass's groups on decode.
struct Folded {
  uint32_t keyword = 0;  // id (kOffValue: the off value of a specialization_constant_int group)
  KeywordKind kind = KeywordKind::SpecializationConstant;
  StageMask stages = kAllStageBits;
  uint32_t slot = 0;  // constant id or byte offset
  uint32_t value = 1, fallback = 0;
};

struct Pass {
  std::string_view name;
  std::array<std::string_view, kStageCount> entry_points{};
  uint32_t first_group = 0, group_count = 0;
  uint32_t first_folded = 0, folded_count = 0;  // in Index::folded
  uint32_t first_variant = 0, variant_count = 0;
};

struct Binary {
  Stage stage = Stage::Vertex;
  std::string_view entry;
  std::array<uint32_t, kTargetCount> blobs{};  // kNone: not built for that target
  uint32_t reflection = 0;
};

// A decoded index: flat tables of views into the bytes it was decoded from (which must outlive it).
struct Index {
  std::vector<std::string_view> keywords;  // K declared, then E undeclared: a keyword's id is its place here
  uint32_t declared_keywords = 0;          // K
  std::vector<Pass> passes;
  std::vector<Group> groups;
  std::vector<uint32_t> values;            // group values: keyword ids or kOffValue
  std::vector<Folded> folded;
  std::vector<Variant> variants;
  std::vector<uint32_t> variant_keywords;  // keyword ids
  std::vector<Binary> binaries;
  std::vector<std::string_view> reflections;  // encoded, checked on decode

  // Checks every count, id and string; `blob_count` is the archive's. Throws IndexError.
  static Index decode(std::string_view bytes, uint64_t blob_count);
  // The id of a keyword, or kNone.
  uint32_t keyword_id(std::string_view name) const;
  // Whether each folded keyword of `pass` (its folded_count, in order) is on for `variant`: its keyword is one of the
  // variant's; the off value of an int group is on when none of its group's keywords is. O((K + F) log K) for K
  // keywords of the variant and F folded keywords, whatever a damaged index holds.
  std::vector<bool> folded_on(const Pass& pass, const Variant& variant) const;
};

// The index of `manifest` (its archive record aside, which it cannot know: the index is inside the archive).
std::string encode(const Manifest& manifest);

std::string encode_reflection(const Reflection& reflection);
// Throws IndexError for a record that is not one kiln writes.
Reflection decode_reflection(std::string_view bytes);

}  // namespace kiln::runtime
