// SPDX-License-Identifier: Apache-2.0
#include <gtest/gtest.h>
#include <algorithm>

#include "frontend/glslang_literals.hpp"

namespace kiln {
namespace {

std::string protect(const std::string& text) { return protect_literals(text).value_or(text); }

TEST(Literals, CharacterLiteralsBecomeTheirValueAtTheSameWidth) {
  EXPECT_EQ(protect("int c = 'A';\n"), "int c = 65 ;\n");
  EXPECT_EQ(protect("int n = '\\n', q = '\\'', b = '\\\\', x = '\\C';\n"), "int n = 10  , q = 39  , b = 92  , x = 67  ;\n");
  EXPECT_EQ(protect("#define L 'B'\n#if 'A' == 65\n#endif\n"), "#define L 66 \n#if 65  == 65\n#endif\n");
}

TEST(Literals, WhatGlslangRefusesIsLeftForGlslangToReport) {
  // Hex and octal escapes, empty and unterminated literals, non-ASCII: glslang's own errors.
  for (const char* text : {"int a = '\\x41';\n", "int a = '\\0';\n", "int a = '';\n", "int a = 'ab';\n",
                           "int a = '\xC3\xA9';\n", "int a = 'A\n';\n"})
    EXPECT_EQ(protect_literals(text), std::nullopt) << text;
}

TEST(Literals, CommentsStringsAndOtherDirectivesAreNotCode) {
  for (const char* text : {"// don't 'A'\n", "/* Karis' 'A' fit\n still 'B' */\n", "#error 'A' is wrong\n",
                           "#pragma message(\"it's 'A'\")\n", "#include \"a\\\\b.hlsl\"\n", "#line 3 \"c:\\\\x.hlsl\"\n",
                           "float s = \"it's\";\n", "// a comment \\\n 'A' continued\n"})
    EXPECT_EQ(protect_literals(text), std::nullopt) << text;
}

TEST(Literals, InfinityBecomesALiteralGlslangReadsAsInfinity) {
  EXPECT_EQ(protect("float f = 1.#INF, g = -1.#INF;\n#define INF 1.#INF\n"),
            "float f = 1e999 , g = -1e999 ;\n#define INF 1e999 \n");
  EXPECT_EQ(protect_literals("float f = 21.#INF, g = x1.#INF;\n"), std::nullopt);
}

TEST(Literals, StringsWithEscapesSurvivePreprocessingExactly) {
  const std::string text = "printf(\"a\\\"b\\\\c\\n\", x);\n#define F \"%d\\n\"\n";
  const std::string shielded = protect(text);
  EXPECT_EQ(shielded.find('\\'), std::string::npos) << shielded;
  EXPECT_EQ(std::count(shielded.begin(), shielded.end(), '\n'), 2);
  // glslang prints a string token as its spelling between quotes: what restore reads back.
  EXPECT_EQ(restore_literals(shielded), text);
  // A string that looks like kiln's own spelling is protected too, so restoring never changes user text.
  const std::string lookalike = "printf(\"__kiln_lit_41\");\n";
  EXPECT_EQ(restore_literals(protect(lookalike)), lookalike);
  EXPECT_EQ(restore_literals("printf(\"plain\");\n"), std::nullopt);
}

TEST(Literals, LineStructureIsKept) {
  const std::string text = "int a = 'A'; /* 'B'\n 'C' */ int b = '\\t';\n\"s\\\"\"\n";
  const std::string shielded = protect(text);
  EXPECT_EQ(std::count(shielded.begin(), shielded.end(), '\n'), std::count(text.begin(), text.end(), '\n'));
  EXPECT_EQ(shielded.substr(0, shielded.find('\n')), "int a = 65 ; /* 'B'");
}

}  // namespace
}  // namespace kiln
