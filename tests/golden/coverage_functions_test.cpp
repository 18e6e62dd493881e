// SPDX-License-Identifier: Apache-2.0
// The function records of kiln test's coverage tracefiles (lcov FN/FNDA): the functions an HLSL file defines,
// found by verify/coverage/hlsl_functions.cpp, on text written to mislead a scan and on the library itself.
#include <gtest/gtest.h>

#include <cctype>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "coverage/hlsl_functions.hpp"

namespace kiln::render {
namespace {

std::vector<std::string> described(const std::vector<HlslFunction>& functions) {
  std::vector<std::string> out;
  for (const HlslFunction& f : functions)
    out.push_back(f.name + " " + std::to_string(f.first_line) + "-" + std::to_string(f.last_line));
  return out;
}

TEST(CoverageFunctions, BracesInCommentsStringsDirectivesAndInitializersAreNotFunctions) {
  const std::string text =
      "// real Fake() { }\n"                                     // 1
      "/* float4 AlsoFake(float x)\n{\n} */\n"                   // 2-4
      "#define BODY(x) { return x; }\n"                          // 5
      "#define LONG(x) \\\n  float x##f() { }\n"                  // 6-7
      "static const float kWeights[2] = { 0.5, 0.5 };\n"         // 8
      "cbuffer Material : register(b0) { float4 tint; };\n"      // 9
      "struct Surface {\n"                                       // 10
      "  float3 albedo;\n"                                       // 11
      "  float3 tinted(float3 t) { return albedo * t; }\n"       // 12
      "};\n"                                                     // 13
      "[numthreads(8, 8, 1)]\n"                                  // 14
      "void CS(uint3 id : SV_DispatchThreadID)\n"                // 15
      "{\n"                                                      // 16
      "  if (id.x > 0) { const char* s = \"}\"; }\n"             // 17
      "}\n"                                                      // 18
      "#if defined(_HALF_PRECISION)\n"                           // 19
      "half F(half x) { return x; }\n"                           // 20
      "#else\n"                                                  // 21
      "float F(float x)\n{\n    return x;\n}\n"                  // 22-25
      "#endif\n"                                                 // 26
      "namespace Lights { vector<float, 3> Dir(float t) : TEXCOORD0 { return t; } }\n"  // 27
      "float4 main(float4 p : SV_Position) : SV_Target { return p; }\n";                // 28
  EXPECT_EQ(described(hlsl_functions(text)),
            (std::vector<std::string>{"Surface::tinted 12-12", "CS 15-18", "F 20-20", "F 22-25", "Lights::Dir 27-27",
                                      "main 28-28"}));
}

TEST(CoverageFunctions, AnUnbalancedFileKeepsTheFunctionsBeforeItsStrayBrace) {
  EXPECT_EQ(described(hlsl_functions("float a() { return 1; }\n}\nfloat b() { return 2; }\n")),
            (std::vector<std::string>{"a 1-1"}));
  EXPECT_EQ(described(hlsl_functions("float a() { return 1; }\nfloat b() { if (x) {\n")),
            (std::vector<std::string>{"a 1-1"}));
  EXPECT_TRUE(hlsl_functions("").empty());
  EXPECT_TRUE(hlsl_functions("/* unterminated { comment").empty());
}

// Against the library's own layout: each definition's name line, up to the first line that is a lone "}".
TEST(CoverageFunctions, FindsEveryTermOfTheBrdfFromItsNameToItsClosingBrace) {
  std::ifstream in(std::string(KILN_SOURCE_DIR) + "/shaderlib/BRDF.hlsl");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_FALSE(text.empty());
  std::vector<std::string> lines;
  for (size_t at = 0; at <= text.size();) {
    const size_t end = std::min(text.find('\n', at), text.size());
    lines.push_back(text.substr(at, end - at));
    at = end + 1;
  }
  const std::vector<HlslFunction> found = hlsl_functions(text);
  for (const char* term : {"D_GGX", "D_GGX_Anisotropic", "V_SmithGGXCorrelated", "F_Schlick", "Fd_Burley", "Fd_Lambert"}) {
    SCOPED_TRACE(term);
    std::vector<uint32_t> expected;
    for (size_t i = 0; i < lines.size(); ++i)
      if (lines[i].find(" " + std::string(term) + "(") != std::string::npos && !lines[i].empty() &&
          !std::isspace(static_cast<unsigned char>(lines[i][0])) && lines[i].rfind("//", 0) != 0)
        expected.push_back(static_cast<uint32_t>(i + 1));
    ASSERT_FALSE(expected.empty());
    std::vector<uint32_t> first_lines;
    for (const HlslFunction& f : found)
      if (f.name == term) {
        first_lines.push_back(f.first_line);
        size_t close = f.first_line;
        while (close < lines.size() && lines[close - 1] != "}") ++close;
        EXPECT_EQ(f.last_line, close) << "the definition at line " << f.first_line;
      }
    EXPECT_EQ(first_lines, expected);
  }
}

}  // namespace
}  // namespace kiln::render
