// SPDX-License-Identifier: Apache-2.0
// Rewrites of the preprocessed HLSL that glslang 12 compiles with another meaning than DXC's, applied before its
// parse. Each keeps the line structure (diagnostics keep their lines) and is tested to give the SPIR-V of the
// spelling glslang reads as DXC does (docs/bindings.md lists them).
#pragma once

#include <cstdint>
#include <optional>
#include <regex>
#include <string>
#include <string_view>
#include <vector>

namespace kiln {

// `[[vk::push_constant]] T name;` with a struct type T: glslang 12 makes it a member of the `$Global` uniform
// buffer at set 0, binding 0 (silently); DXC makes it a push-constant block. Rewritten to
// `[[vk::push_constant]] ConstantBuffer<T> name;`, which glslang makes a push-constant block. The attribute may
// stand on a line of its own, among others in its group or beside other groups (`[[vk::push_constant]]
// [[vk::binding(0)]]`), with comments between. A struct declared with its variable (`[[vk::push_constant]] struct
// { ... } pc;`) is declared first and its variable made the same way. Nothing when the text has no such declaration.
std::optional<std::string> rewrite_push_constants(std::string_view text);

// Attribute lists (`[[vk::binding(0), vk::push_constant]]`), which DXC takes and glslang 12's grammar refuses
// ("']' : Expected"): rewritten to one group per attribute, `[[vk::binding(0)]][[vk::push_constant]]`, on the same
// line. Commas inside an attribute's arguments stay. Nothing when the text has no list.
std::optional<std::string> rewrite_attribute_lists(std::string_view text);

// HLSL 2021's `select(c, a, b)`, `and(a, b)` and `or(a, b)`, which glslang 12 does not have: rewritten to HLSL 2018's
// componentwise `((c) ? (a) : (b))`, `((a) && (b))` and `((a) || (b))`, which DXC gives the same meaning and glslang
// compiles to OpSelect, OpLogicalAnd and OpLogicalOr. A call is rewritten only when its arguments are complete (the
// parentheses balance within it) and their count is right; a text that declares a function of one of these names
// keeps its own. Nothing when the text calls none of them.
std::optional<std::string> rewrite_hlsl2021_intrinsics(std::string_view text);

// Swizzles of scalar literals (`0.xxxx`, `1.0.xxxx`, `0.5f.rg`), which DXC takes and glslang's preprocessor splits
// into a number and a word (`0. xxxx`, `1.0 . xxxx`): rewritten to `(0).xxxx`, `(1.0).xxxx`. Nothing when the text
// has none.
std::optional<std::string> rewrite_literal_swizzles(std::string_view text);

// `enum Name [: T] { A, B = 3, C };` and `enum class`/`enum struct`, which glslang 12 refuses ("'enum' : Reserved
// word"): rewritten to `typedef T Name; namespace Name { static const T A = ...; }` (T defaults to int, as in DXC),
// and for an unscoped enum `static const T A = Name::A;` beside it, so that `Name`, `Name::A` and (unscoped) `A`
// mean what DXC makes of them. Each enumerator is declared on its own line. Nothing when the text declares none.
std::optional<std::string> rewrite_enums(std::string_view text);

// RWByteAddressBuffer's atomic methods (`buffer.InterlockedAdd(offset, 1)`), whose value arguments DXC converts to
// uint and glslang 12 passes as written: with an int argument its SPIR-V fails validation ("AtomicIAdd: expected
// Value to be of type Result Type", no line). Each value argument (not the offset, not the original-value output)
// becomes `(uint)(argument)`. Nothing when the text calls none.
std::optional<std::string> rewrite_byte_address_atomics(std::string_view text);

// `[[vk::offset(N)]]` on a member of a struct or cbuffer, which glslang 12 ignores (with a warning kiln made an
// error): each attribute is blanked (columns kept) and recorded, and write_member_offsets (dxc_semantics.hpp) puts
// the offsets into glslang's SPIR-V, or says why one cannot be. Nothing when the text states none on a member.
struct StatedOffset {
  std::string record;                // the struct or cbuffer
  std::vector<std::string> members;  // the record's data members, in order (a ConstantBuffer<T> block is named
                                     // after its variable: glslang's type is found by them)
  std::string member;
  uint32_t offset = 0;
  size_t at = 0;  // of the word `offset` in the text
};
struct MemberOffsets {
  std::string text;
  std::vector<StatedOffset> stated;
};
std::optional<MemberOffsets> strip_member_offsets(std::string_view text);

// Names DXC takes and glslang 12's HLSL scanner reserves (`Texture2D texture;`, `SamplerState sampler;`: glslang
// said "';' : Expected", pointing at nothing): when the text declares one as a name, every use of the word becomes
// `kiln_reserved_<word>`, and restore_reserved_names (dxc_semantics.hpp) gives the SPIR-V its own name back, so the
// reflection and the targets see the author's. Nothing when the text declares none.
inline constexpr std::string_view kReservedNamePrefix = "kiln_reserved_";
std::optional<std::string> rewrite_reserved_names(std::string_view text);

// `InterlockedCompareStore(dest, compare, value)` (and RWByteAddressBuffer's method), which glslang 12 drops with
// only a warning ("Missing functionality: unknown glslang aggregate"): the shader stored nothing. Rewritten to
// `InterlockedCompareExchange(dest, compare, value, kiln_compare_store_original)`, its DXC meaning with the original
// value unread; the front end declares the variable (kCompareStoreOriginalDeclaration) in its preamble.
inline constexpr std::string_view kCompareStoreOriginalDeclaration = "static uint kiln_compare_store_original;\n";
std::optional<std::string> rewrite_compare_store(std::string_view text);

// `[[vk::...]]` attributes that change a shader's interface in DXC and that glslang 12 ignores with only a warning
// ("'offset' : unrecognized attribute"): the interface kiln would build is not the one the author wrote, so each
// is an error, saying what DXC does with it and what to write instead, never advice already in force (turning on
// combined image samplers when `combined_image_samplers` says they are on). `warning` is the front end's message
// text; nothing when it is no such attribute.
std::optional<std::string> interface_attribute_error(std::string_view warning, bool combined_image_samplers);

// The matches of `declaration` in `text` that start at file scope (brace depth 0), in order. The depth is counted
// once over the text, whatever the number of matches (a file of 100,000 declarations stays linear); `declaration`
// must bound its repetitions, as std::regex recurses per character it repeats.
std::vector<std::smatch> file_scope_matches(const std::string& text, const std::regex& declaration);

}  // namespace kiln
