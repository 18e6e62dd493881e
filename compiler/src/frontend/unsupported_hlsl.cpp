// SPDX-License-Identifier: Apache-2.0
#include "frontend/unsupported_hlsl.hpp"

#include <array>
#include <cctype>
#include <regex>

namespace kiln {
namespace {

// How a construct shows in glslang's first error.
enum class Seen {
  Quoted,        // the message quotes the word: "'select' : no matching overloaded function found"
  QuotedPrefix,  // the message quotes a word starting with it: 'float16_t3'
  QuotedNamespaced,  // the message quotes an unknown qualified name: "'Shading::Light' : unknown variable"
  InLine,        // the word is on the line the message points at ("'declaration' : Expected")
  Pattern,       // the line matches `word` as a regular expression
};

struct Row {
  Seen seen;
  std::string_view word;
  std::string_view construct;
  std::string_view advice;
};

// In the order checked: the first row that matches names the construct.
constexpr std::array kRows{
    // HLSL 2021's select/and/or are rewritten before glslang parses (frontend/hlsl_compat.hpp): glslang's own
    // message for a call with a wrong argument count is the right one.
    Row{Seen::Quoted, "template", "templates (HLSL 2021)", "write one function per type, or generate them with a macro"},
    Row{Seen::Quoted, "enum", "`enum`", "declare the enum apart from its variables (`enum Mode { A, B }; Mode mode;`), which kiln compiles, or use `static const uint` constants"},
    Row{Seen::Quoted, "using", "type aliases with `using`", "write `typedef float real;`"},
    Row{Seen::QuotedNamespaced, "", "types declared in a namespace",
        "declare the type at file scope (functions in a namespace work)"},
    Row{Seen::QuotedPrefix, "float16_t", "the `float16_t` type names",
        "with 16-bit types on (kiln always enables them) `half`, `half2`, `half3x3`, ... are 16-bit floats: spell them so"},
    Row{Seen::QuotedPrefix, "int16_t", "the `int16_t` type names",
        "glslang 12's HLSL has no spelling for a 16-bit integer: use `int`"},
    Row{Seen::QuotedPrefix, "uint16_t", "the `uint16_t` type names",
        "glslang 12's HLSL has no spelling for a 16-bit integer: use `uint`"},
    Row{Seen::Quoted, "ResourceDescriptorHeap", "Shader Model 6.6 dynamic resources (`ResourceDescriptorHeap`)",
        "declare each resource, with a register or `[[vk::binding]]` (docs/bindings.md)"},
    Row{Seen::Quoted, "SamplerDescriptorHeap", "Shader Model 6.6 dynamic resources (`SamplerDescriptorHeap`)",
        "declare each sampler, with a register or `[[vk::binding]]` (docs/bindings.md)"},
    Row{Seen::InLine, "RaytracingAccelerationStructure", "ray tracing (`RaytracingAccelerationStructure`)",
        "glslang 12's HLSL front end has no ray tracing types; compile ray tracing shaders with DXC"},
    Row{Seen::Quoted, "RayQuery", "inline ray tracing (`RayQuery`)",
        "glslang 12's HLSL front end has no ray tracing types; compile ray tracing shaders with DXC"},
    Row{Seen::InLine, "outputtopology", "mesh shaders", "glslang 12's HLSL front end has no mesh or amplification stage"},
    Row{Seen::InLine, "SetMeshOutputCounts", "mesh shaders", "glslang 12's HLSL front end has no mesh or amplification stage"},
    Row{Seen::InLine, "DispatchMesh", "amplification shaders", "glslang 12's HLSL front end has no mesh or amplification stage"},
    Row{Seen::QuotedPrefix, "dot4add_", "Shader Model 6.4 packed dot products (`dot4add_u8packed`, `dot4add_i8packed`)",
        "unpack the bytes with shifts and masks and use `dot`"},
    Row{Seen::QuotedPrefix, "pack_", "Shader Model 6.6 packing intrinsics (`pack_u8`, `pack_s8`, `pack_clamp_*`)",
        "pack with shifts and masks"},
    Row{Seen::QuotedPrefix, "unpack_", "Shader Model 6.6 unpacking intrinsics (`unpack_u8u32`, ...)",
        "unpack with shifts and masks"},
    Row{Seen::InLine, "static_assert", "`static_assert`", "check at preprocessing time with `#if ... #error ... #endif`"},
    Row{Seen::InLine, "constexpr", "`constexpr`", "write `static const`"},
    // glslang names a texture method's built-in `__BI_<Method>`: a call with no overload (the `status` overloads).
    Row{Seen::QuotedPrefix, "__BI_",
        "this call of a texture method with these arguments (one it lacks: the `status` argument of Sample, SampleLevel, "
        "SampleCmp, SampleGrad, Gather and Load, which DXC uses to read a tiled resource's residency)",
        "if the call passes `status`, drop it and `CheckAccessFullyMapped`: kiln cannot keep its meaning (DXC's "
        "OpImageSparse* instructions); otherwise check the arguments' count and types"},
    Row{Seen::Pattern, R"(\boperator\s*(\(\s*\)|[^\w\s(]+)\s*\()", "operator overloading (HLSL 2021)",
        "write a named function (`Add(a, b)`)"},
    Row{Seen::Pattern, R"(\b[A-Za-z_]\w*\s+[A-Za-z_]\w*\s*:\s*[0-9]+\s*[;,])", "bit fields (HLSL 2021)",
        "store the fields in a `uint` and read them with shifts and masks"},
};

bool is_word_char(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; }

// The 1-based column of `word` as a whole word in `line` (before a `//` comment); 0 when absent.
int word_column(std::string_view line, std::string_view word) {
  line = line.substr(0, line.find("//"));
  for (size_t at = line.find(word); at != std::string_view::npos; at = line.find(word, at + 1)) {
    const bool starts = at == 0 || !is_word_char(line[at - 1]);
    const bool ends = at + word.size() == line.size() || !is_word_char(line[at + word.size()]);
    if (starts && ends) return static_cast<int>(at) + 1;
  }
  return 0;
}

// The word a glslang message starts by quoting ("'select' : ..."); empty when none.
std::string_view quoted_word(std::string_view message) {
  if (!message.starts_with('\'')) return {};
  const size_t end = message.find('\'', 1);
  return end == std::string_view::npos ? std::string_view{} : message.substr(1, end - 1);
}

}  // namespace

std::optional<UnsupportedHlsl> recognise_unsupported_hlsl(std::string_view message, std::string_view line) {
  const std::string_view quoted = quoted_word(message);
  const std::string_view code = line.substr(0, line.find("//"));
  for (const Row& row : kRows) {
    int column = 0;
    switch (row.seen) {
      case Seen::Quoted:
        if (quoted != row.word) continue;
        column = word_column(line, row.word);
        break;
      case Seen::QuotedPrefix: {
        if (!quoted.starts_with(row.word)) continue;
        column = word_column(line, quoted);
        if (column == 0 && quoted.starts_with("__BI_")) column = word_column(line, quoted.substr(5));  // `.Sample(`
        break;
      }
      case Seen::QuotedNamespaced:
        if (quoted.find("::") == std::string_view::npos || !message.ends_with(": unknown variable")) continue;
        column = word_column(line, quoted);
        break;
      case Seen::InLine:
        column = word_column(line, row.word);
        if (column == 0) continue;
        break;
      case Seen::Pattern: {
        std::match_results<std::string_view::const_iterator> match;
        if (!std::regex_search(code.begin(), code.end(), match, std::regex(row.word.begin(), row.word.end()))) continue;
        column = static_cast<int>(match.position(0)) + 1;
        break;
      }
    }
    return UnsupportedHlsl{std::string(row.construct), std::string(row.advice), column};
  }
  return std::nullopt;
}

}  // namespace kiln
