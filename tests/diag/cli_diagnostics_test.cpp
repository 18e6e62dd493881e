// SPDX-License-Identifier: Apache-2.0
// Each bad input gets an exact diagnostic (checked to the byte), a non-zero exit code, and leaves no
// pack and no cache entry behind.
#include <gtest/gtest.h>
#include <linux/fs.h>
#include <sys/ioctl.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>

#include <cstring>
#include <future>
#include <map>
#include <regex>

#include <nlohmann/json.hpp>

#include "cache/cache.hpp"
#include "cross/targets.hpp"
#include "frontend/frontend.hpp"
#include "kiln/build.hpp"
#include "optimize/spirv_tools.hpp"
#include "kiln/pack_reader.hpp"
#include "test_support.hpp"

namespace kiln {
namespace {

const char* kPack = R"({"name": "p", "include_dirs": ["lib"], "budget": 64,
  "passes": [{"name": "P", "source": "S.hlsl", "stages": {"vertex": "V", "fragment": "F"}}]})";

const char* kEntries =
    "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
    "float4 F() : SV_Target { return 1.0; }\n";

struct Cli : ::testing::Test {
  testing::TempDir dir;
  void SetUp() override { dir.write("p.pack.json", kPack); }
  testing::RunResult build(std::vector<std::string> extra = {}) {
    std::vector<std::string> args{"build", "p.pack.json", "-o", "out", "--cache", "cache", "-q"};
    args.insert(args.end(), extra.begin(), extra.end());
    return testing::run_kiln(args, dir.path());
  }
  // Builds with `extra` arguments and expects exit code 1, exactly `err` on stderr, and nothing written.
  void expect_build_error(const std::string& err, std::vector<std::string> extra = {}) {
    auto r = build(std::move(extra));
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_EQ(r.err, err);
    expect_nothing_written();
  }
  void expect_nothing_written() {
    for (const auto& f : testing::files_below(dir / "out"))
      EXPECT_EQ(f.string().find("kiln-ice"), f.string().size() - f.filename().string().size() - 9) << "left behind: " << f;
    EXPECT_TRUE(testing::files_below(dir / "cache").empty()) << "cache entries left behind";
  }
};

// A bug report needs every tool's version and the optimizer recipe: --version names them as the cache keys and
// manifests do.
TEST_F(Cli, VersionNamesEveryToolKilnWasBuiltWith) {
  auto r = testing::run_kiln({"--version"}, dir.path());
  EXPECT_EQ(r.exit_code, 0);
  const size_t stock = optimizer_pass_names(OptimizerRecipe::Stock).size();
  const size_t left_out = stock - optimizer_pass_names(OptimizerRecipe::Kiln).size();
  const std::string expected = std::string("kiln ") + kKilnVersion + "\nfront end: glslang " + make_frontend("glslang")->version() +
                               "\nSPIRV-Tools: " + spirv_tools_version() + "\noptimizer recipe: kiln (default; -O without " +
                               std::to_string(left_out) + " of its " + std::to_string(stock) +
                               " passes), O with --optimize=O\nSPIRV-Cross: " + spirv_cross_version() + "\nallocator: ";
  EXPECT_GT(left_out, 0u);
  EXPECT_EQ(r.out.substr(0, expected.size()), expected) << r.out;
  EXPECT_NE(spirv_cross_version().find("libraries sha256 "), std::string::npos);
}

TEST_F(Cli, SyntaxErrorIsReportedAtItsLineDespiteThePreamble) {
  dir.write("S.hlsl", "#pragma multi_compile _ A\n\nfloat4 V(float4 p : POSITION) : SV_Position { return p; }\n"
                      "float4 F() : SV_Target {\n  float4 c = undefinedThing;\n  return c;\n}\n");
  expect_build_error("S.hlsl:5:14: error[K1401]: 'undefinedThing' : unknown variable\n"
                     "      float4 c = undefinedThing;\n"
                     "                 ^\n"
                     "  note: in pass 'P' vertex stage, keywords [<none>]\n"
                     "  note: and in 1 more variant(s)\n"
                     "kiln: 1 error(s)\n");
}

// A #line directive can name any path; diagnostics quote only files the build itself read (through the
// confined includer), so a pull request cannot make `kiln lint` print CI secrets or /etc/passwd.
TEST_F(Cli, LineDirectivesNamingFilesTheBuildDidNotReadAreShownByNameOnly) {
  testing::TempDir outside;
  const std::string marker = "KILN_SECRET_MARKER";
  auto secret = outside.write("secret.txt", marker + "_1\n" + marker + "_2\n" + marker + "_3\n");
  dir.write("lib/NeverIncluded.hlsl", marker + "_IN_ROOT_1\n" + marker + "_IN_ROOT_2\n");
  ::setenv("KILN_TEST_SECRET", (marker + "_ENV").c_str(), 1);
  for (const std::string& named : {secret.string(), std::string("../") + outside.path().filename().string() + "/secret.txt",
                                   std::string("lib/NeverIncluded.hlsl"), std::string("/proc/self/environ")}) {
    dir.write("S.hlsl", "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
                        "#line 2 \"" + named + "\"\n"
                        "float4 F() : SV_Target { return undefinedThing; }\n");
    auto r = build();
    EXPECT_EQ(r.exit_code, 1) << named;
    EXPECT_EQ(r.err, named + ":2: error[K1401]: 'undefinedThing' : unknown variable\n"
                     "  note: in pass 'P' vertex stage, keywords [<none>]\n"
                     "  note: and in 1 more variant(s)\n"
                     "kiln: 1 error(s)\n");
    EXPECT_EQ(r.err.find(marker), std::string::npos) << r.err;
  }
  ::unsetenv("KILN_TEST_SECRET");
  // A file the build read is quoted (here the entry, whose line 2 the directive itself now is).
  dir.write("S.hlsl", "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
                      "#line 2 \"S.hlsl\"\n"
                      "float4 F() : SV_Target { return undefinedThing; }\n");
  EXPECT_EQ(build().err, "S.hlsl:2: error[K1401]: 'undefinedThing' : unknown variable\n"
                         "    #line 2 \"S.hlsl\"\n"
                         "  note: in pass 'P' vertex stage, keywords [<none>]\n"
                         "  note: and in 1 more variant(s)\n"
                         "kiln: 1 error(s)\n");
}

// SPIRV-Cross sizes blocks in 32 bits: a 4 GiB cbuffer was reflected as 0 bytes and the build passed.
TEST_F(Cli, ABufferBlockOf4GiBIsAnErrorAtItsDeclaration) {
  dir.write("S.hlsl", "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
                      "cbuffer Huge {\n  float4 table[268435456];\n};\n"
                      "float4 F() : SV_Target { return table[7]; }\n");
  expect_build_error("S.hlsl:2:9: error[K1409]: buffer block 'Huge' is 4294967296 bytes; a block must be under 4 GiB "
                     "(SPIR-V offsets are 32-bit)\n"
                     "    cbuffer Huge {\n"
                     "            ^\n"
                     "  note: in pass 'P' vertex stage, keywords [<none>]\n"  // declared there too: checked before DCE
                     "  note: and in 1 more variant(s)\n"
                     "kiln: 1 error(s)\n");
  // Just under the limit is a valid layout, reflected in full.
  dir.write("S.hlsl", "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
                      "cbuffer Large {\n  float4 table[268435455];\n};\n"
                      "float4 F() : SV_Target { return table[7]; }\n");
  ASSERT_EQ(build().exit_code, 0);
  const auto manifest = nlohmann::json::parse(testing::read_file(dir / "out/p.manifest.json"));
  EXPECT_NE(manifest.dump().find("\"size\":4294967280"), std::string::npos);
}

// The same limit for every kind of block, checked on the front end's module while the names are there: two
// members adding up to 4 GiB wrapped their offsets (K1403, spirv-val), a tbuffer was K1409 named '_19' and with
// no line, a structured buffer's 4 GiB element was an internal error (SPIRV-Cross threw).
TEST_F(Cli, EveryKindOfBufferBlockOf4GiBIsAnErrorAtItsDeclaration) {
  const struct {
    const char* declaration;
    const char* use;
    std::string err;
  } cases[] = {
      {"cbuffer Pair {\n  float4 a[134217728];\n  float4 b[134217728];\n};\n", "a[0] + b[0]",
       "S.hlsl:2:9: error[K1409]: buffer block 'Pair' is 4294967296 bytes; a block must be under 4 GiB (SPIR-V offsets "
       "are 32-bit)\n"},
      {"tbuffer Texels {\n  float4 t[268435456];\n};\n", "t[0]",
       "S.hlsl:2:9: error[K1409]: buffer block 'Texels' is 4294967296 bytes; a block must be under 4 GiB (SPIR-V "
       "offsets are 32-bit)\n"},
      {"struct Element { float4 e[268435456]; };\nStructuredBuffer<Element> elements;\n", "elements[0].e[0]",
       "S.hlsl:3:27: error[K1409]: buffer block 'elements' is 4294967296 bytes; a block must be under 4 GiB (SPIR-V "
       "offsets are 32-bit)\n"},
  };
  for (const auto& c : cases) {
    dir.write("S.hlsl", std::string("float4 V(float4 p : POSITION) : SV_Position { return p; }\n") + c.declaration +
                            "float4 F() : SV_Target { return " + c.use + "; }\n");
    auto r = build();
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_EQ(r.err.substr(0, r.err.find('\n') + 1), c.err) << r.err;
  }
}

// glslang reports lines only; kiln finds the column from the token a message quotes. "';' : Expected" quotes
// the token glslang wanted, so the caret went to another ';' of the line (column 48 here): no column instead.
TEST_F(Cli, AMissingTokenGetsNoColumnRatherThanAWrongOne) {
  dir.write("S.hlsl", "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
                      "float4 F() : SV_Target { float x = 1.0 return x; }\n");
  expect_build_error("S.hlsl:2: error[K1401]: ';' : Expected\n"
                     "    float4 F() : SV_Target { float x = 1.0 return x; }\n"
                     "  note: in pass 'P' vertex stage, keywords [<none>]\n"
                     "  note: and in 1 more variant(s)\n"
                     "kiln: 1 error(s)\n");
}

// Locations recovered where glslang gives them another way: the HLSL grammar's own "error at column N, HLSL
// parsing failed" (was "S.hlsl: frontend failed", with no line; its column counts in the preprocessed text, whose
// spacing, comments and macros are not the file's, so the caret goes on the same token of the file's line), and a
// directive's error, which glslang reports on the line after the directive.
TEST_F(Cli, ParseFailuresAndDirectiveErrorsAreReportedAtTheirOwnLine) {
  dir.write("S.hlsl", "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
                      "float4 F() : SV_Target { return 1; } }\n");
  expect_build_error("S.hlsl:2:38: error[K1401]: HLSL parsing failed\n"
                     "    float4 F() : SV_Target { return 1; } }\n"
                     "                                         ^\n"
                     "  note: in pass 'P' vertex stage, keywords [<none>]\n"
                     "  note: and in 1 more variant(s)\n"
                     "kiln: 1 error(s)\n");
  // glslang parsed `float4 F(): SV_Target { return 1; } }` and points at the stray brace; the file's line has a
  // comment with a brace in it, wider spaces and a macro before it.
  dir.write("S.hlsl", "#define ONE 1\nfloat4 V(float4 p : POSITION) : SV_Position { return p; }\n"
                      "    float4 F() : SV_Target { return /* } */ ONE;   } }\n");
  expect_build_error("S.hlsl:3:54: error[K1401]: HLSL parsing failed\n"
                     "        float4 F() : SV_Target { return /* } */ ONE;   } }\n"
                     "                                                         ^\n"
                     "  note: in pass 'P' vertex stage, keywords [<none>]\n"
                     "  note: and in 1 more variant(s)\n"
                     "kiln: 1 error(s)\n");
  dir.write("S.hlsl", "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
                      "  #if\nfloat4 F() : SV_Target { return 1; }\n#endif\n");
  expect_build_error("S.hlsl:2:3: error[K1408]: 'preprocessor evaluation' : bad expression\n"
                     "      #if\n"
                     "      ^\n"
                     "  note: in pass 'P' vertex stage, keywords [<none>]\n"
                     "  note: and in 1 more variant(s)\n"
                     "kiln: 1 error(s)\n");
}

TEST_F(Cli, MissingIncludeListsTheRootsSearched) {
  dir.write("S.hlsl", std::string("#include \"Missing.hlsl\"\n") + kEntries);
  std::filesystem::create_directories(dir / "lib");
  expect_build_error("S.hlsl:1:10: error[K1201]: cannot find include file 'Missing.hlsl'\n"
                     "    #include \"Missing.hlsl\"\n"
                     "             ^\n"
                     "  note: searched: .\n"
                     "  note: searched: lib\n"
                     "  note: searched: .\n"
                     "kiln: 1 error(s)\n");
}

// An include written as on Windows, where DXC users wrote it (another case, backslashes): the error names the file
// it differs from only in that, as kiln's include names are case-sensitive and use '/'.
TEST_F(Cli, AnIncludeThatDiffersOnlyInCaseOrSlashesNamesTheFile) {
  dir.write("lib/Common/Lighting.hlsli", "static const float kAmbient = 0.1;\n");
  dir.write("S.hlsl", std::string("#include \"common\\LIGHTING.hlsli\"\n") + kEntries);
  expect_build_error("S.hlsl:1:10: error[K1201]: cannot find include file 'common\\LIGHTING.hlsli'\n"
                     "    #include \"common\\LIGHTING.hlsli\"\n"
                     "             ^\n"
                     "  note: a file differs only in case or slash direction: #include \"Common/Lighting.hlsli\" (lib/Common/Lighting.hlsli)\n"
                     "  note: searched: .\n"
                     "  note: searched: lib\n"
                     "  note: searched: .\n"
                     "kiln: 1 error(s)\n");
  // A file that differs in more than that gets no hint.
  dir.write("S.hlsl", std::string("#include \"Common/Lights.hlsli\"\n") + kEntries);
  auto r = build();
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err.find("differs only"), std::string::npos) << r.err;
}

TEST_F(Cli, IncludeCyclePrintsTheChain) {
  dir.write("lib/A.hlsl", "#include \"B.hlsl\"\n");
  dir.write("lib/B.hlsl", "#include \"A.hlsl\"\n");
  dir.write("S.hlsl", std::string("#include \"A.hlsl\"\n") + kEntries);
  auto r = build();
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err,
            "lib/B.hlsl:1:10: error[K1203]: #include cycle: 'lib/A.hlsl' includes itself\n"
            "    #include \"A.hlsl\"\n"
            "             ^\n"
            "  note: lib/A.hlsl includes lib/B.hlsl\n"
            "  note: lib/B.hlsl includes lib/A.hlsl\n"
            "  note: add '#pragma once' or an include guard, or remove the #include\n"
            "kiln: 1 error(s)\n");
  expect_nothing_written();
}

TEST_F(Cli, IncludeEscapingTheRootIsRefused) {
  dir.write("lib/S2.hlsl", "#include \"../../secret.hlsl\"\n");
  dir.write("S.hlsl", std::string("#include \"S2.hlsl\"\n") + kEntries);
  auto r = build();
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("lib/S2.hlsl:1:10: error[K1202]: #include \"../../secret.hlsl\" resolves to '"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("', outside the include roots\n"), std::string::npos) << r.err;
  expect_nothing_written();
}

TEST_F(Cli, IncludeOfADirectoryOrFifoIsRefused) {
  std::filesystem::create_directories(dir / "lib/Dir.hlsl");
  ASSERT_EQ(::mkfifo((dir / "lib/Fifo.hlsl").c_str(), 0644), 0);
  dir.write("S.hlsl", std::string("#include \"Dir.hlsl\"\n") + kEntries);
  auto r = build();
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("S.hlsl:1:10: error[K1002]: '"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("Dir.hlsl' is a directory, not a regular file\n"), std::string::npos) << r.err;
  dir.write("S.hlsl", std::string("#include \"Fifo.hlsl\"\n") + kEntries);
  r = build();
  EXPECT_EQ(r.exit_code, 1);
  // A FIFO that kiln opened for reading would block it forever: ctest's timeout, not a clock here, fails that.
  EXPECT_NE(r.err.find("Fifo.hlsl' is a FIFO, not a regular file\n"), std::string::npos) << r.err;
  expect_nothing_written();
}

TEST_F(Cli, FileOverTheSizeLimitIsRefused) {
  dir.write("lib/Huge.hlsl", std::string(5u << 20, ' '));
  dir.write("S.hlsl", std::string("#include \"Huge.hlsl\"\n") + kEntries);
  auto r = build();
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("S.hlsl:1:10: error[K1003]: '"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("Huge.hlsl' is 5242880 bytes, over the limit of 4194304 bytes\n"), std::string::npos) << r.err;
  expect_nothing_written();
}

TEST_F(Cli, BinaryJunkAndNulBytesAreNotText) {
  dir.write("S.hlsl", std::string("float4 x;\n\xff\xfe junk\n") + kEntries);
  auto r = build();
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err.substr(0, r.err.find('\n')), "S.hlsl:2:1: error[K1004]: file is not valid UTF-8 text (byte 0xFF)");
  dir.write("S.hlsl", std::string("float4 x;\nfloat4 y\0;\n", 21) + kEntries);
  r = build();
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err.substr(0, r.err.find('\n')), "S.hlsl:2:9: error[K1004]: file contains a NUL byte; is 'S.hlsl' a binary file?");
  expect_nothing_written();
}

TEST_F(Cli, Utf8ByteOrderMarkIsAccepted) {
  dir.write("S.hlsl", std::string("\xEF\xBB\xBF") + kEntries);
  auto r = build();
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err, "");
  EXPECT_TRUE(std::filesystem::exists(dir / "out/p.manifest.json"));
}

TEST_F(Cli, UnknownKeywordSuggestsTheClosestDeclaredOne) {
  dir.write("S.hlsl", std::string("#pragma multi_compile _ _MAIN_LIGHT_SHADOWS\n") + kEntries);
  dir.write("p.pack.json", R"({"name": "p", "passes": [{"name": "P", "source": "S.hlsl",
  "stages": {"vertex": "V", "fragment": "F"}}],
  "constraints": [{"keyword": "_MAIN_LIGHT_SHADOW", "requires": ["_MAIN_LIGHT_SHADOWS"]}]})");
  expect_build_error("p.pack.json:3:32: error[K1303]: unknown keyword '_MAIN_LIGHT_SHADOW' in constraint: no pass declares it\n"
                     "      \"constraints\": [{\"keyword\": \"_MAIN_LIGHT_SHADOW\", \"requires\": [\"_MAIN_LIGHT_SHADOWS\"]}]}\n"
                     "                                   ^\n"
                     "  note: did you mean '_MAIN_LIGHT_SHADOWS'?\n"
                     "kiln: 1 error(s)\n");
}

TEST_F(Cli, UnknownFieldInAPackOrSceneIsAnErrorSuggestingTheClosestKnownOne) {
  dir.write("S.hlsl", kEntries);
  dir.write("p.pack.json", R"({"name": "p", "budjet": 64,
  "passes": [{"name": "P", "source": "S.hlsl", "stages": {"vertex": "V", "fragment": "F"}, "colour": 1}]})");
  expect_build_error("p.pack.json:1:16: error[K1011]: unknown field \"budjet\" in the pack definition\n"
                     "    {\"name\": \"p\", \"budjet\": 64,\n"
                     "                   ^\n"
                     "  note: did you mean \"budget\"?\n"
                     "p.pack.json:2:93: error[K1011]: unknown field \"colour\" in a pass\n"
                     "      \"passes\": [{\"name\": \"P\", \"source\": \"S.hlsl\", \"stages\": {\"vertex\": \"V\", \"fragment\": \"F\"}, \"colour\": 1}]}\n"
                     "                                                                                                ^\n"
                     "  note: known fields: name, description, source, stages, targets, bindings, defines\n"
                     "kiln: 2 error(s)\n");

  dir.write("p.pack.json", kPack);
  dir.write("scene.json", R"({"name": "s", "keywords": ["A"], "material": ["standard"]})");
  expect_build_error("scene.json:1:35: error[K1012]: unknown field \"material\" in the scene profile\n"
                     "    {\"name\": \"s\", \"keywords\": [\"A\"], \"material\": [\"standard\"]}\n"
                     "                                      ^\n"
                     "  note: did you mean \"materials\"?\n"
                     "kiln: 1 error(s)\n", {"--scene", "scene.json"});
}

TEST_F(Cli, InvalidJsonIsReportedAtItsLineAndColumn) {
  dir.write("S.hlsl", kEntries);
  dir.write("p.pack.json", "{\"name\": \"p\",\n  \"passes\": [{\"name\": \"P\", \"source\": \"S.hlsl\",}]}\n");
  expect_build_error("p.pack.json:2:47: error[K1010]: invalid JSON: syntax error while parsing object key - unexpected '}'; "
                     "expected string literal\n"
                     "      \"passes\": [{\"name\": \"P\", \"source\": \"S.hlsl\",}]}\n"
                     "                                                  ^\n"
                     "kiln: 1 error(s)\n");
}

TEST_F(Cli, MalformedAndTooDeepIncludesAreErrors) {
  dir.write("S.hlsl", std::string("#include Missing.hlsl\n") + kEntries);
  expect_build_error("S.hlsl:1:1: error[K1205]: expected #include \"file\" or #include <file>\n"
                     "    #include Missing.hlsl\n"
                     "    ^\n"
                     "kiln: 1 error(s)\n");
  // A chain of 70 files, each including the next: refused at the 64th level, not a stack overflow.
  for (int i = 0; i < 70; ++i)
    dir.write("lib/D" + std::to_string(i) + ".hlsl", "#include \"D" + std::to_string(i + 1) + ".hlsl\"\n");
  dir.write("lib/D70.hlsl", "// the end\n");
  dir.write("S.hlsl", std::string("#include \"D0.hlsl\"\n") + kEntries);
  expect_build_error("lib/D62.hlsl:1:10: error[K1204]: #include nesting is deeper than 64\n"
                     "    #include \"D63.hlsl\"\n"
                     "             ^\n"
                     "kiln: 1 error(s)\n");
}

// 24 files, each including the next twice without a guard, are 2^24 inclusions: the includer stops at
// its bound with an error naming the include line, instead of preprocessing for minutes at gigabytes.
TEST_F(Cli, AnIncludeBombIsAnErrorNotAnEndlessPreprocess) {
  for (int i = 0; i < 24; ++i)
    dir.write("lib/B" + std::to_string(i) + ".hlsl",
              i == 23 ? std::string("float bomb_leaf() { return 1.0; }\n")
                      : "#include \"B" + std::to_string(i + 1) + ".hlsl\"\n#include \"B" + std::to_string(i + 1) + ".hlsl\"\n");
  dir.write("S.hlsl", std::string("#include \"B0.hlsl\"\n") + kEntries);
  expect_build_error("lib/B20.hlsl:1:1: error[K1408]: '#include' : more than 20000 #include expansions in one stage "
                     "source (files included again and again without an include guard?) for header name: B21.hlsl\n"
                     "    #include \"B21.hlsl\"\n"
                     "    ^\n"
                     "  note: in pass 'P' vertex stage, keywords [<none>]\n"
                     "  note: and in 1 more variant(s)\n"
                     "kiln: 1 error(s)\n");
}

TEST_F(Cli, PreprocessorErrorsAreReportedOnceAtTheirOwnLine) {
  // After #error glslang's preprocessor stops; the "missing #endif" it reports next is not the user's.
  dir.write("S.hlsl", std::string("#pragma multi_compile _ A\n#ifdef A\n#error A is not supported here\n#endif\n") + kEntries);
  expect_build_error("S.hlsl:3:1: error[K1408]: '#error' : A is not supported here\n"
                     "    #error A is not supported here\n"
                     "    ^\n"
                     "  note: in pass 'P' vertex stage, keywords [A]\n"
                     "  note: and in 1 more variant(s)\n"
                     "kiln: 1 error(s)\n");
  // Unbalanced conditionals are found once per file, at their own line, before any variant is preprocessed.
  dir.write("lib/Open.hlsl", "#ifndef OPEN_INCLUDED\n#define OPEN_INCLUDED\n#if 0\n#endif\n");
  dir.write("S.hlsl", std::string("#include \"Open.hlsl\"\n#else\n") + kEntries);
  expect_build_error("lib/Open.hlsl:1:1: error[K1408]: #if without #endif in this file (a conditional closes in the file that "
                     "opens it)\n"
                     "    #ifndef OPEN_INCLUDED\n"
                     "    ^\n"
                     "S.hlsl:2:1: error[K1408]: #else without #if\n"
                     "    #else\n"
                     "    ^\n"
                     "kiln: 2 error(s)\n");
}

TEST_F(Cli, ConstraintsThatLeaveAPassNoVariantAreAnError) {
  dir.write("S.hlsl", std::string("#pragma multi_compile A\n#pragma multi_compile _ B\n") + kEntries);
  dir.write("p.pack.json", R"({"name": "p", "passes": [{"name": "P", "source": "S.hlsl", "stages": {"vertex": "V", "fragment": "F"}}],
  "constraints": [{"keyword": "A", "requires": ["B"]}, {"keyword": "B", "excludes": ["A"]}]})");
  expect_build_error("p.pack.json:1:36: error[K1305]: constraints and scene profiles leave pass 'P' with no variant\n"
                     "    {\"name\": \"p\", \"passes\": [{\"name\": \"P\", \"source\": \"S.hlsl\", \"stages\": {\"vertex\": \"V\", \"fragment\": \"F\"}}],\n"
                     "                                       ^\n"
                     "kiln: 1 error(s)\n");
}

TEST_F(Cli, CodeATargetCannotExpressIsAnErrorNamingTheTarget) {
  // ddx_fine is SPIR-V's DPdxFine: fine for Vulkan, desktop GL and Metal; OpenGL ES has no derivative control.
  dir.write("S.hlsl", "#pragma multi_compile_fragment _ FINE\n"
                      "float4 V(float4 p : POSITION, inout float4 c : COLOR0) : SV_Position { return p; }\n"
                      "float4 F(float4 c : COLOR0) : SV_Target {\n"
                      "#ifdef FINE\n  return float4(ddx_fine(c.x), 0.0, 0.0, 1.0);\n#else\n  return c;\n#endif\n}\n");
  expect_build_error("S.hlsl: error[K1405]: cross-gles: GL_ARB_derivative_control is unavailable in OpenGL ES.\n"
                     "  note: in pass 'P' fragment stage, keywords [FINE]\n"
                     "  note: SPIRV-Cross cannot write this for the 'gles' target; if this pass does not need it, give the pass "
                     "\"targets\" without \"gles\" (or remove it from the pack's, or build with --targets)\n"
                     "kiln: 1 error(s)\n");
  // Without GLSL ES, the same shader builds.
  auto r = build({"--targets", "spirv,glsl,msl"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
}

TEST_F(Cli, KeywordDeclaredInTwoGroupsIsAnError) {
  dir.write("S.hlsl", std::string("#pragma multi_compile _ A B\n#pragma multi_compile_fragment _ B C\n") + kEntries);
  expect_build_error("S.hlsl:2:1: error[K1302]: keyword 'B' is already declared in another keyword group\n"
                     "    #pragma multi_compile_fragment _ B C\n"
                     "    ^\n"
                     "  note: first declared at S.hlsl:1\n"
                     "kiln: 1 error(s)\n");
}

TEST_F(Cli, TwoToTheFortyVariantsFailAgainstTheBudgetBeforeCompiling) {
  std::string pragmas;
  for (int i = 0; i < 40; ++i) pragmas += "#pragma multi_compile _ K" + std::to_string(i) + "\n";
  dir.write("S.hlsl", pragmas + kEntries);
  auto r = build();
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err.substr(0, r.err.find('\n')),
            "p.pack.json:1:41: error[K1304]: pack 'p' has more than 64 variants after stripping (1099511627776 declared), "
            "over its budget of 64");
  EXPECT_NE(r.err.find("  note: largest group: P: #pragma multi_compile _ K0 (2 values, S.hlsl:1)\n"), std::string::npos) << r.err;
  expect_nothing_written();
}

TEST_F(Cli, MissingEntryPointIsAnError) {
  dir.write("S.hlsl", "float4 V(float4 p : POSITION) : SV_Position { return p; }\nfloat4 Frag() : SV_Target { return 1.0; }\n");
  expect_build_error("p.pack.json:2:87: error[K1402]: entry point 'F' of the fragment stage is not defined in 'S.hlsl'\n"
                     "      \"passes\": [{\"name\": \"P\", \"source\": \"S.hlsl\", \"stages\": {\"vertex\": \"V\", \"fragment\": \"F\"}}]}\n"
                     "                                                                                          ^\n"
                     "  note: in pass 'P' fragment stage, keywords [<none>]\n"
                     "kiln: 1 error(s)\n");
}

TEST_F(Cli, GlslangCrashIsAnInternalErrorWithAReproducerAndTheRestIsStillBuilt) {
  dir.write("S.hlsl",
            "#pragma multi_compile_fragment _ CRASH\n"
            "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
            "#ifdef CRASH\nfloat4 F(float4) : SV_Target { return 0; }\n"
            "#else\nfloat4 F() : SV_Target { return 1.0; }\n#endif\n");
  auto r = build();
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("S.hlsl: error[K1501]: internal compiler error: the compiler worker killed by signal 11 "
                       "(Segmentation fault) while compiling pass 'P' fragment stage, keywords [CRASH]\n"),
            std::string::npos)
      << r.err;
  auto repro = dir / "out/kiln-ice/P.fragment.CRASH.hlsl";
  ASSERT_TRUE(std::filesystem::exists(repro)) << r.err;
  EXPECT_NE(testing::read_file(repro).find("float4 F(float4)"), std::string::npos);
  // The other variants were compiled and cached (per stage source: its alias and its module's result);
  // the crash was not. Every source's preprocessing memo is kept (3).
  EXPECT_EQ(Cache(dir / "cache").indexed_keys(), 7u);
  EXPECT_FALSE(std::filesystem::exists(dir / "out/p.manifest.json"));
}

TEST_F(Cli, ReadOnlyOutputDirectoryIsReportedAndNothingIsWritten) {
  dir.write("S.hlsl", kEntries);
  std::filesystem::create_directories(dir / "out");
  // Root ignores permission bits, so make the directory immutable when running as root.
  bool immutable = false;
  if (::geteuid() == 0) {
    int fd = ::open((dir / "out").c_str(), O_RDONLY | O_DIRECTORY);
    int flags = 0;
    if (fd >= 0 && ::ioctl(fd, FS_IOC_GETFLAGS, &flags) == 0) {
      flags |= FS_IMMUTABLE_FL;
      immutable = ::ioctl(fd, FS_IOC_SETFLAGS, &flags) == 0;
    }
    if (fd >= 0) ::close(fd);
    ASSERT_TRUE(immutable) << "cannot make a read-only directory for root on this file system";
  } else {
    std::filesystem::permissions(dir / "out", std::filesystem::perms::owner_read | std::filesystem::perms::owner_exec);
  }
  auto r = build();
  if (immutable) {
    int fd = ::open((dir / "out").c_str(), O_RDONLY | O_DIRECTORY);
    int flags = 0;
    ::ioctl(fd, FS_IOC_GETFLAGS, &flags);
    flags &= ~FS_IMMUTABLE_FL;
    ::ioctl(fd, FS_IOC_SETFLAGS, &flags);
    ::close(fd);
  }
  EXPECT_EQ(r.exit_code, 3);  // the machine's fault, not the input's (diagnostics.def's exit classes)
  EXPECT_EQ(r.err, "out: error[K1601]: output directory 'out' is not writable\nkiln: 1 error(s)\n");
  EXPECT_TRUE(testing::files_below(dir / "out").empty());
}

TEST_F(Cli, FailedRebuildLeavesThePreviousPackIntact) {
  dir.write("S.hlsl", kEntries);
  ASSERT_EQ(build().exit_code, 0);
  std::string manifest = testing::read_file(dir / "out/p.manifest.json");
  std::string archive = testing::read_archive(dir / "out/p.manifest.json");
  dir.write("S.hlsl", std::string("float4 V(float4 p : POSITION) : SV_Position { return p }\n") + "float4 F() : SV_Target { return 1.0; }\n");
  EXPECT_EQ(build().exit_code, 1);
  EXPECT_EQ(testing::read_file(dir / "out/p.manifest.json"), manifest);
  EXPECT_EQ(testing::read_archive(dir / "out/p.manifest.json"), archive);
}

// Two fragment keywords: 1 vertex and 4 fragment stage sources.
const char* kTwoKeywords =
    "#pragma multi_compile_fragment _ A\n#pragma multi_compile_fragment _ B\n"
    "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
    "float4 F() : SV_Target {\n  float4 c = 0.25;\n#ifdef A\n  c.r = 1.0;\n#endif\n#ifdef B\n  c.g = 1.0;\n#endif\n"
    "  return c;\n}\n";

TEST_F(Cli, WithoutATerminalABuildPrintsTheFunnelAndStageTimesOnceAndNoProgressLine) {
  dir.write("S.hlsl", kTwoKeywords);
  auto r = testing::run_kiln({"build", "p.pack.json", "-o", "out", "--cache", "cache", "-j", "2"}, dir.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err, "");  // no progress in a CI log, not even erased
  const std::string head = "kiln: wrote out/p.manifest.json\n"
                           "  variants: 4 declared -> 4 valid -> 4 after stripping -> 8 stage variants -> "
                           "5 unique per stage -> 5 compiles -> 5 modules -> 5 unique binaries\n"
                           "  compiled 5 (back ends 5, full legalizations 0, cached back ends 0), cache hits 0 "
                           "(not preprocessed 0), workers 2\n"
                           "  time: ";
  EXPECT_EQ(r.out.substr(0, head.size()), head) << r.out;
  // The wall time first, then every stage with its time, in pipeline order.
  const std::string times = r.out.substr(r.out.find("  time: "));
  const std::string time_line = times.substr(0, times.find('\n'));
  EXPECT_TRUE(std::regex_search(time_line, std::regex("^  time: [0-9]+[.][0-9]+ m?s wall: load "))) << r.out;
  std::string stages;
  const std::regex stage_time("[:,] ([a-z+ ]+) [0-9]+[.][0-9]+ m?s");
  for (std::sregex_iterator m(time_line.begin(), time_line.end(), stage_time), end; m != end; ++m)
    stages += (*m)[1].str() + ";";
  EXPECT_EQ(stages, "load;declarations;expand+strip;preprocess;dedupe;compile;cache store;reflect;pack;") << r.out;
  // Then the workers' busy time, summed over them (the overlapping stages' CPU, not their wall time).
  EXPECT_TRUE(std::regex_search(times, std::regex("\n  workers: [0-9]+[.][0-9]+ m?s busy, summed over 2 workers: "
                                                   "preprocess [0-9]+[.][0-9]+ m?s, compile [0-9]+[.][0-9]+ m?s; "
                                                   "idle [0-9]+[.][0-9]+ m?s\n$")))
      << r.out;
  EXPECT_EQ(r.out.back(), '\n');
  EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 5) << r.out;
}

// A diagnostic in colour is the same text with ANSI colours: location and message bold, the severity red,
// notes cyan, the caret green. Auto colours a terminal only, and NO_COLOR or TERM=dumb turn it off.
TEST_F(Cli, DiagnosticsAreColouredOnATerminalUnlessNoColorAndOnRequest) {
  dir.write("S.hlsl", "#pragma multi_compile _ A\n#pragma multi_compile _ A\n" + std::string(kEntries));
  const auto plain = build({"--color=never"});
  ASSERT_EQ(plain.exit_code, 1);
  ASSERT_NE(plain.err.find("error[K"), std::string::npos) << plain.err;
  EXPECT_EQ(plain.err.find('\033'), std::string::npos);
  EXPECT_EQ(build().err, plain.err);  // auto: stderr is a file here
  const auto coloured = build({"--color=always"});
  EXPECT_EQ(coloured.exit_code, 1);
  EXPECT_NE(coloured.err.find("\033[1mS.hlsl:2:"), std::string::npos) << coloured.err;
  EXPECT_NE(coloured.err.find("\033[1;31merror[K"), std::string::npos) << coloured.err;
  EXPECT_NE(coloured.err.find("\033[1;32m^\033[0m"), std::string::npos) << coloured.err;
  // Without its escapes, the coloured text is the plain one.
  EXPECT_EQ(std::regex_replace(coloured.err, std::regex("\033\\[[0-9;]*m"), ""), plain.err);
  // --color before the verb works too; an unknown mode is an argument error.
  EXPECT_EQ(testing::run_kiln({"--color=always", "build", "p.pack.json", "-o", "out", "-q", "--no-cache"}, dir.path()).err,
            coloured.err);
  EXPECT_EQ(build({"--color=sometimes"}).exit_code, 1);

  const std::vector<std::string> on_terminal{KILN_CLI_PATH, "build", "p.pack.json", "-o", "out", "--cache", "cache", "-q"};
  EXPECT_NE(testing::run_on_terminal(on_terminal, dir.path()).out.find("\033[1;31merror["), std::string::npos);
  EXPECT_EQ(testing::run_on_terminal(on_terminal, dir.path(), "dumb").out.find('\033'), std::string::npos);
  ::setenv("NO_COLOR", "1", 1);
  const std::string no_color = testing::run_on_terminal(on_terminal, dir.path()).out;
  auto always = on_terminal;
  always.push_back("--color=always");
  const std::string forced = testing::run_on_terminal(always, dir.path()).out;
  ::unsetenv("NO_COLOR");
  EXPECT_EQ(no_color.find('\033'), std::string::npos) << no_color;
  EXPECT_NE(forced.find("\033[1;31merror["), std::string::npos);
}

// --summary-json: the summary's numbers for CI dashboards, written whether the build succeeds or not.
TEST_F(Cli, SummaryJsonRecordsTheBuildForDashboardsEvenWhenItFails) {
  dir.write("S.hlsl", kTwoKeywords);
  auto r = build({"--summary-json", "summary.json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json summary = nlohmann::json::parse(testing::read_file(dir / "summary.json"));
  const nlohmann::json manifest = nlohmann::json::parse(testing::read_file(dir / "out/p.manifest.json"));
  EXPECT_EQ(summary.at("ok"), true);
  EXPECT_EQ(summary.at("exit_code"), 0);
  EXPECT_EQ(summary.at("errors"), 0);
  EXPECT_EQ(summary.at("up_to_date"), false);
  EXPECT_EQ(summary.at("manifest"), "out/p.manifest.json");
  for (const auto& [field, value] : manifest.at("funnel").items()) EXPECT_EQ(summary.at("funnel").at(field), value) << field;
  EXPECT_EQ(summary.at("compiled"), 5);
  EXPECT_EQ(summary.at("cache_hits"), 0);
  EXPECT_EQ(summary.at("remote").at("configured"), false);
  std::string stages;
  for (const auto& t : summary.at("timings")) {
    stages += t.at("stage").get<std::string>() + ";";
    EXPECT_GE(t.at("milliseconds").get<double>(), 0.0);
  }
  EXPECT_EQ(stages, "load;declarations;expand+strip;preprocess;dedupe;compile;cache store;reflect;pack;total;");
  // The timeline: stages by start and end; preprocessing streams into the compile, so the compile stage starts
  // before the last source is preprocessed (an order, not a duration: it holds however fast the machine is).
  std::map<std::string, nlohmann::json> stage;
  for (const auto& t : summary.at("timings")) {
    stage[t.at("stage").get<std::string>()] = t;
    EXPECT_LE(t.at("start_ms").get<double>(), t.at("end_ms").get<double>()) << t;
  }
  EXPECT_LE(stage["compile"].at("start_ms").get<double>(), stage["preprocess"].at("end_ms").get<double>());
  ASSERT_FALSE(summary.at("worker_timeline").empty());
  size_t jobs = 0;
  for (const auto& w : summary.at("worker_timeline")) {
    jobs += w.at("jobs").get<size_t>();
    if (w.at("first_compile_ms").is_null()) continue;
    EXPECT_GE(w.at("first_compile_ms").get<double>(), w.at("spawned_ms").get<double>()) << w;
    EXPECT_GE(w.at("idle_before_first_compile_ms").get<double>(), 0.0) << w;
  }
  EXPECT_GE(jobs, 5u + 5u);  // at least a Preprocess job and a front end per stage source

  r = build({"--summary-json", "summary.json"});
  const nlohmann::json up_to_date = nlohmann::json::parse(testing::read_file(dir / "summary.json"));
  EXPECT_EQ(up_to_date.at("up_to_date"), true);
  EXPECT_TRUE(up_to_date.at("worker_timeline").empty());  // no worker started

  dir.write("S.hlsl", "#error broken\n" + std::string(kEntries));
  r = build({"--summary-json", "summary.json"});
  EXPECT_EQ(r.exit_code, 1);
  const nlohmann::json failed = nlohmann::json::parse(testing::read_file(dir / "summary.json"));
  EXPECT_EQ(failed.at("ok"), false);
  EXPECT_EQ(failed.at("exit_code"), 1);
  EXPECT_GE(failed.at("errors").get<int>(), 1);
  EXPECT_TRUE(failed.at("manifest").is_null());

  std::filesystem::create_directory(dir / "taken");
  r = build({"--summary-json", "taken"});
  EXPECT_EQ(r.exit_code, 3);  // an output not written is worse than the shader's error: the environment's class wins
  EXPECT_NE(r.err.find("kiln: error[K1601]: --summary-json: "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("kiln: 2 error(s)\n"), std::string::npos) << r.err;  // the shader's, and the summary's
}

// `-` is standard output for the single-file outputs: --summary-json (the summary for people moves to standard
// error) and lint's -o. No file named "-" is written.
TEST_F(Cli, DashWritesTheSummaryJsonOrTheLintReportToStandardOutput) {
  dir.write("S.hlsl", kTwoKeywords);
  auto r = testing::run_kiln({"build", "p.pack.json", "-o", "out", "--cache", "cache", "--summary-json", "-"}, dir.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json summary = nlohmann::json::parse(r.out);
  EXPECT_EQ(summary.at("ok"), true);
  EXPECT_EQ(summary.at("compiled"), 5);
  EXPECT_NE(r.err.find("kiln: wrote out/p.manifest.json"), std::string::npos) << r.err;
  auto lint = testing::run_kiln({"lint", "S.hlsl", "--format", "json", "-o", "-"}, dir.path());
  EXPECT_EQ(lint.exit_code, 0) << lint.err;
  EXPECT_TRUE(nlohmann::json::parse(lint.out).is_object()) << lint.out;
  // --depfile - as well (it wrote a file named `-`): the depfile alone on standard output with -q.
  auto depfile = testing::run_kiln({"build", "p.pack.json", "-o", "out", "--cache", "cache", "-q", "--depfile", "-"}, dir.path());
  ASSERT_EQ(depfile.exit_code, 0) << depfile.err;
  EXPECT_EQ(depfile.out.rfind("out/p.manifest.json:", 0), 0u) << depfile.out;
  EXPECT_NE(depfile.out.find("S.hlsl"), std::string::npos) << depfile.out;
  EXPECT_FALSE(std::filesystem::exists(dir / "-"));
}

// Usage-driven stripping end to end (docs/usage.md): a run recorded by the reader, a pack built from its log, and
// check-usage on that pack against the log and against another run's.
TEST_F(Cli, UsageLogsStripAPackToWhatTheRunsAskedForAndCheckUsageFindsWhatItLacks) {
  dir.write("S.hlsl", kTwoKeywords);  // variants [], [A], [B], [A B]
  ASSERT_EQ(build().exit_code, 0);
  auto record = [&](const std::string& file, const std::vector<std::vector<std::string>>& selections) {
    PackReader reader = PackReader::open(dir / "out");
    reader.record_usage({dir / file, {{"scene", "forest"}}});
    for (const auto& keywords : selections) reader.select("P", keywords);
  };
  record("run1.json", {{"A"}, {"A"}, {"A", "B"}, {"A"}});
  record("run2.json", {{"B"}});

  auto r = testing::run_kiln({"build", "p.pack.json", "-o", "narrow", "--cache", "cache", "--usage", "run1.json"}, dir.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("P: usage log run1.json (2 keyword sets): 4 -> 2 (variants this run did not ask for)"),
            std::string::npos) << r.out;
  {
    PackReader narrow = PackReader::open(dir / "narrow");
    EXPECT_EQ(narrow.variant_count("P"), 2u);
    EXPECT_EQ(narrow.select("P", {"A"}).keywords, std::vector<std::string>{"A"});
    EXPECT_EQ(narrow.select("P", {"A", "B"}).keywords, (std::vector<std::string>{"A", "B"}));
  }
  auto ok = testing::run_kiln({"check-usage", "narrow", "run1.json"}, dir.path());
  EXPECT_EQ(ok.exit_code, 0) << ok.err;
  EXPECT_EQ(ok.out, "kiln check-usage: 1 log, 2 keyword sets asked for (4 selections): 0 not in the pack (0 selections)\n");
  auto missed = testing::run_kiln({"check-usage", "narrow", "run1.json", "run2.json"}, dir.path());
  EXPECT_EQ(missed.exit_code, 1);
  EXPECT_EQ(missed.err, "run2.json: error[K1307]: pass 'P': [B], asked for 1 time, is not in pack 'p'; the nearest variant "
                        "the reader names is [A B]\n");
  EXPECT_NE(missed.out.find(": 1 not in the pack (1 selection)"), std::string::npos) << missed.out;

  // Both runs: every variant they asked for; a margin of one group keeps the neighbours too.
  r = testing::run_kiln({"build", "p.pack.json", "-o", "both", "--cache", "cache", "--usage", "run1.json", "--usage", "run2.json",
                         "--usage-tag", "scene=forest"}, dir.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("P: usage (2 logs): 4 -> 3 (variants no run asked for)"), std::string::npos) << r.out;
  r = testing::run_kiln({"build", "p.pack.json", "-o", "margin", "--cache", "cache", "--usage", "run2.json", "--usage-margin", "1"},
                        dir.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(PackReader::open(dir / "margin").variant_count("P"), 3u);  // [B], and [] and [A B] one group away

  // Merged, the two runs are one log with the counts added, written as the readers write one; a pack built from it
  // is the pack built from both.
  {
    PackReader reader = PackReader::open(dir / "out");
    reader.record_usage({dir / "run3.json", {{"scene", "city"}}});
    reader.select("P", {"A"});
  }
  auto merged = testing::run_kiln({"merge-usage", "run1.json", "run2.json", "run3.json", "--usage-tag", "scene=forest",
                                   "-o", "merged.json"}, dir.path());
  ASSERT_EQ(merged.exit_code, 0) << merged.err;
  EXPECT_EQ(merged.out, "kiln merge-usage: 2 logs merged (1 without the tags), 1 pass, 3 keyword sets, 5 selections "
                        "-> merged.json\n");
  EXPECT_EQ(testing::read_file(dir / "merged.json"), R"({
  "format": "kiln-usage",
  "format_version": 1,
  "pack": "p",
  "tags": {
    "scene": "forest"
  },
  "passes": [
    {
      "name": "P",
      "served": [
        {
          "keywords": [
            "A"
          ],
          "count": 3
        },
        {
          "keywords": [
            "A",
            "B"
          ],
          "count": 1
        },
        {
          "keywords": [
            "B"
          ],
          "count": 1
        }
      ],
      "missing": []
    }
  ],
  "missing_dropped": 0
}
)");
  r = testing::run_kiln({"build", "p.pack.json", "-o", "from-merged", "--cache", "cache", "--usage", "merged.json"}, dir.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(PackReader::open(dir / "from-merged").variant_count("P"), 3u);
  // Every log, to standard output (the summary to standard error): the tags they do not share are dropped; a
  // missing request stays missing, with its nearest variant. Only another pass: nothing of P.
  {
    PackReader reader = PackReader::open(dir / "narrow");
    reader.record_usage({dir / "run4.json", {{"scene", "forest"}}});
    EXPECT_THROW(reader.select("P", {"B"}), PackError);
  }
  merged = testing::run_kiln({"merge-usage", "run1.json", "run3.json", "run4.json", "-o", "-"}, dir.path());
  ASSERT_EQ(merged.exit_code, 0) << merged.err;
  EXPECT_EQ(merged.err, "kiln merge-usage: 3 logs merged (0 without the tags), 1 pass, 3 keyword sets, 6 selections\n");
  const nlohmann::json all = nlohmann::json::parse(merged.out);
  EXPECT_TRUE(all.at("tags").empty()) << all;
  EXPECT_EQ(all.at("passes")[0].at("served")[0], (nlohmann::json{{"keywords", {"A"}}, {"count", 4}})) << all;
  EXPECT_EQ(all.at("passes")[0].at("missing"),
            (nlohmann::json::array({{{"keywords", {"B"}}, {"count", 1}, {"nearest", {"A", "B"}}}}))) << all;
  merged = testing::run_kiln({"merge-usage", "run1.json", "--pass", "Q", "-o", "-"}, dir.path());
  ASSERT_EQ(merged.exit_code, 0) << merged.err;
  EXPECT_TRUE(nlohmann::json::parse(merged.out).at("passes").empty()) << merged.out;

  // Mistakes: a tag no log has, a log of another pack, a log that is not one.
  r = testing::run_kiln({"build", "p.pack.json", "-o", "x", "--usage", "run1.json", "--usage-tag", "scene=city"}, dir.path());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("error[K1015]: none of the 1 usage logs has the tags scene=city"), std::string::npos) << r.err;
  std::string other = testing::read_file(dir / "run1.json");
  other.replace(other.find("\"pack\": \"p\""), 11, "\"pack\": \"q\"");
  dir.write("other.json", other);
  r = testing::run_kiln({"build", "p.pack.json", "-o", "x", "--usage", "other.json"}, dir.path());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("other.json:4:4: error[K1015]: this usage log is of pack 'q', not of 'p'"), std::string::npos) << r.err;
  r = testing::run_kiln({"merge-usage", "run1.json", "other.json", "-o", "x.json"}, dir.path());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err.substr(0, r.err.find('\n')),
            "other.json:4:4: error[K1015]: this usage log is of pack 'q', the first log (run1.json) of 'p': logs of "
            "different packs cannot be merged") << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "x.json"));
  dir.write("broken.json", R"({"format": "kiln-usage", "format_version": 2, "pack": "p", "tags": {}, "passes": [], "missing_dropped": 0})");
  r = testing::run_kiln({"check-usage", "narrow", "broken.json"}, dir.path());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("broken.json:1:27: error[K1015]: usage log format version 2 is not supported (this kiln reads version 1)"),
            std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "x"));
}

// A shader written for Unity names its stages with `#pragma vertex` / `#pragma fragment`: a pass without "stages"
// takes them; a pack whose stages disagree is told so. Unity's other pragmas are supported (multi_compile_instancing)
// or a located note (target, exclude_renderers), once a line, never silence.
TEST_F(Cli, UnityPragmasNameTheStagesAndTheOthersAreSupportedOrNoted) {
  dir.write("S.hlsl", std::string("#pragma vertex V\n#pragma fragment F\n#pragma target 4.5\n#pragma multi_compile_instancing\n"
                                  "#pragma exclude_renderers gles d3d11\n") + kEntries +
                          "float4 G() : SV_Target { return 0.5; }\n");
  dir.write("p.pack.json", R"({"name": "p", "passes": [{"name": "P", "source": "S.hlsl"}, {"name": "Q", "source": "S.hlsl"}]})");
  auto r = build();
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err, "S.hlsl:3:9: note[K1310]: '#pragma target' is Unity's: kiln does not act on it (kiln compiles for the "
                   "targets the pack names, the SPIR-V for Vulkan 1.1 (SPIR-V 1.3))\n"
                   "    #pragma target 4.5\n"
                   "            ^\n"
                   "S.hlsl:5:9: note[K1310]: '#pragma exclude_renderers' is Unity's: kiln does not act on it (every pass is "
                   "built for the pack's targets: give the pass \"targets\" of its own)\n"
                   "    #pragma exclude_renderers gles d3d11\n"
                   "            ^\n");
  {
    PackReader pack = PackReader::open(dir / "out");
    EXPECT_EQ(pack.variant_count("P"), 2u);  // INSTANCING_ON off and on
    EXPECT_EQ(pack.select("P", {"INSTANCING_ON"}).keywords, std::vector<std::string>{"INSTANCING_ON"});
    const ManifestPass& pass = pack.manifest().passes.front();
    EXPECT_EQ(pass.entry_points.at(Stage::Vertex), "V");
    EXPECT_EQ(pass.entry_points.at(Stage::Fragment), "F");
  }
  // The pack's stages win over the pragmas, with a warning at the pragma that disagrees.
  dir.write("p.pack.json", R"({"name": "p", "passes": [{"name": "P", "source": "S.hlsl", "stages": {"vertex": "V", "fragment": "G"}}]})");
  r = build();
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("S.hlsl:2:18: warning[K1311]: '#pragma fragment F' disagrees with pass 'P' of the pack, whose fragment "
                       "stage is 'G': the pack's stages are used"), std::string::npos) << r.err;
  EXPECT_EQ(PackReader::open(dir / "out").manifest().passes.front().entry_points.at(Stage::Fragment), "G");
  // kiln compile without -E takes the stage's entry point from its pragma (the file has no `main`), and says nothing
  // of the vertex pragma of a stage it does not build.
  auto compiled = testing::run_kiln({"compile", "S.hlsl", "-S", "frag", "-o", "f.spv"}, dir.path());
  EXPECT_EQ(compiled.exit_code, 0) << compiled.err;
  EXPECT_EQ(compiled.err.find("K1311"), std::string::npos) << compiled.err;
  EXPECT_TRUE(std::filesystem::exists(dir / "f.spv"));
  // Neither stages nor pragmas: an error at the pass.
  dir.write("T.hlsl", kEntries);
  dir.write("p.pack.json", R"({"name": "p", "passes": [{"name": "P", "source": "T.hlsl"}]})");
  r = build();
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("error[K1311]: pass 'P' has no \"stages\" and its source names none with '#pragma vertex NAME'"),
            std::string::npos) << r.err;
}

// A run that asked for what the pack cannot keep (a set its constraints strip, a keyword it does not declare) is
// said at `build --usage`, once a set, not only later by check-usage; the set with no keyword on is never "[]" alone.
TEST_F(Cli, UsageBuildsSayWhichRequestedKeywordSetsThePackStrips) {
  dir.write("S.hlsl", kTwoKeywords);  // variants [], [A], [B], [A B]
  dir.write("p.pack.json", R"({"name": "p", "passes": [{"name": "P", "source": "S.hlsl", "stages": {"vertex": "V", "fragment": "F"}}],
  "constraints": [{"keyword": "B", "excludes": ["A"]}]})");
  ASSERT_EQ(build().exit_code, 0);
  auto log = [&](const std::string& file, const std::string& served) {
    dir.write(file, "{\"format\": \"kiln-usage\", \"format_version\": 1, \"pack\": \"p\", \"tags\": {}, \"passes\": "
                    "[{\"name\": \"P\", \"served\": [" + served + "], \"missing\": []}], \"missing_dropped\": 0}\n");
  };
  log("run1.json", R"({"keywords": ["A"], "count": 2}, {"keywords": ["A", "B"], "count": 1}, {"keywords": ["C"], "count": 1})");
  log("run2.json", R"({"keywords": ["A", "B"], "count": 5}, {"keywords": [], "count": 1})");
  auto r = testing::run_kiln({"build", "p.pack.json", "-o", "narrow", "--cache", "cache", "--usage", "run1.json", "--usage", "run2.json"},
                             dir.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err, "run1.json: warning[K1309]: pass 'P': [A B], asked for 1 time, is stripped by this pack's constraints, "
                   "materials or scenes: the pack built from this log lacks it, and a reader asking for it gets its nearest variant\n"
                   "run1.json: warning[K1309]: pass 'P': [C], asked for 1 time, is a keyword set this pass cannot express (a "
                   "keyword it does not declare, or two of one group): the pack built from this log lacks it, and a reader "
                   "asking for it gets its nearest variant\n");
  EXPECT_NE(r.out.find("P: usage log run1.json (2 keyword sets): 3 -> 1"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("P: usage (2 logs): 3 -> 2"), std::string::npos) << r.out;
  // check-usage names the nearest variant; the one with no keyword on is [<none>], as every message names it.
  auto check = testing::run_kiln({"check-usage", "narrow", "run2.json"}, dir.path());
  EXPECT_EQ(check.exit_code, 1);
  EXPECT_EQ(check.err, "run2.json: error[K1307]: pass 'P': [A B], asked for 5 times, is not in pack 'p'; the nearest variant "
                       "the reader names is [A]\n");
  log("run3.json", R"({"keywords": ["B"], "count": 1})");
  check = testing::run_kiln({"check-usage", "narrow", "run3.json"}, dir.path());
  EXPECT_NE(check.err.find("[B], asked for 1 time, is not in pack 'p'; the nearest variant the reader names is [<none>]"),
            std::string::npos) << check.err;
  EXPECT_EQ(check.out, "kiln check-usage: 1 log, 1 keyword set asked for (1 selection): 1 not in the pack (1 selection)\n");
}

// merge-usage wrote logs whose pack was "", "../lit" or "lit\u0000" (a name no other verb accepts); -D with a value
// of 120,000 characters was glslang's bare "name too long". Both are refused at the input, with the value cut short.
TEST_F(Cli, MergeUsageRefusesALogWhosePackIsNoPackNameAndALongDefineIsRefusedByName) {
  for (const std::string pack : {"", "../lit", "lit\\u0000"}) {
    dir.write("bad.json", "{\"format\": \"kiln-usage\", \"format_version\": 1, \"pack\": \"" + pack +
                              "\", \"tags\": {}, \"passes\": [], \"missing_dropped\": 0}\n");
    auto r = testing::run_kiln({"merge-usage", "bad.json", "-o", "merged.json"}, dir.path());
    EXPECT_EQ(r.exit_code, 1) << pack;
    EXPECT_NE(r.err.find("bad.json:1:48: error[K1015]: \"pack\": '"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("' is not a pack name: it "), std::string::npos) << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir / "merged.json")) << pack;
  }
  dir.write("S.hlsl", kTwoKeywords);
  auto r = testing::run_kiln({"build", "p.pack.json", "-o", "out", "--cache", "cache", "-D", "V=" + std::string(120000, 'x')},
                             dir.path());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err, "<command line>: error[K1014]: -D 'V=" + std::string(62, 'x') +
                       "... (120002 bytes)': the value of 'V' holds a name or number longer than the 1023 characters the "
                       "preprocessor reads (expected -D NAME or -D NAME=VALUE)\n");
}

TEST_F(Cli, OnATerminalABuildShowsOneProgressLineAndErasesItBeforeTheSummary) {
  dir.write("S.hlsl", kTwoKeywords);
  const std::vector<std::string> cold{KILN_CLI_PATH, "build", "p.pack.json", "-o", "out", "--cache", "cache"};
  auto r = testing::run_on_terminal(cold, dir.path());
  ASSERT_EQ(r.exit_code, 0) << r.out;
  // Drawn at the start and at the end, each time over the previous one; never a new line of its own.
  const std::string first = "\rkiln: 0/5 stage sources (0%)\033[K";
  EXPECT_EQ(r.out.substr(0, first.size()), first) << r.out;
  const size_t last = r.out.find("\rkiln: 5/5 stage sources (100%), ");
  ASSERT_NE(last, std::string::npos) << r.out;
  EXPECT_EQ(r.out.find('\n'), r.out.find("kiln: wrote") + 31) << r.out;
  // Erased before the summary, which then starts at the beginning of the line.
  const size_t summary = r.out.find("\r\033[Kkiln: wrote out/p.manifest.json\n  variants: 4 declared");
  EXPECT_GT(summary, last) << r.out;
  EXPECT_EQ(r.out.find("\r", summary + 1), std::string::npos) << "drawn after the summary: " << r.out;

  // Into another directory: every stage source comes from the cache.
  auto warm = cold;
  warm[4] = "out2";
  r = testing::run_on_terminal(warm, dir.path());
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_NE(r.out.find("\rkiln: 5/5 stage sources (100%), cache hits 5\033[K\r\033[Kkiln: wrote out2/p.manifest.json\n"),
            std::string::npos) << r.out;

  // -q prints nothing at all; a terminal that cannot erase a line (TERM=dumb, or none) gets no progress line.
  auto quiet = cold;
  quiet[4] = "out3";
  quiet.push_back("-q");
  EXPECT_EQ(testing::run_on_terminal(quiet, dir.path()).out, "");
  for (const char* term : {"dumb", ""}) {
    auto plain = cold;
    plain[4] = std::string("out-") + (*term ? term : "none");
    r = testing::run_on_terminal(plain, dir.path(), term);
    ASSERT_EQ(r.exit_code, 0) << r.out;
    EXPECT_EQ(r.out.find_first_of("\r\033"), std::string::npos) << term << ": " << r.out;
    EXPECT_EQ(r.out.substr(0, 11), "kiln: wrote") << r.out;
  }
}

TEST_F(Cli, OnATerminalADiagnosticDuringTheBuildStartsOnAClearedLine) {
  dir.write("S.hlsl",
            "#pragma multi_compile_fragment _ CRASH\n"
            "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
            "#ifdef CRASH\nfloat4 F(float4) : SV_Target { return 0; }\n"
            "#else\nfloat4 F() : SV_Target { return 1.0; }\n#endif\n");
  // Uncoloured, to match the text (colour is DiagnosticsAreColouredOnATerminalUnlessNoColorAndOnRequest's).
  auto r = testing::run_on_terminal({KILN_CLI_PATH, "build", "p.pack.json", "-o", "out", "--cache", "cache", "--color=never"},
                                    dir.path());
  EXPECT_EQ(r.exit_code, 2);
  const size_t error = r.out.find("S.hlsl: error[K1501]: internal compiler error: the compiler worker killed by signal 11");
  ASSERT_NE(error, std::string::npos) << r.out;
  // How many of the other jobs finish before the crash depends on the scheduler, so the property is
  // asserted, not one interleaving: before the diagnostic, nothing or progress lines, each drawn over
  // the previous one, and then the line erased.
  static const std::regex redraws(R"(^((\rkiln: [0-3]/3 stage sources \([0-9]+%\)[^\r\n\x1b]*\x1b\[K)+\r\x1b\[K)?$)");
  EXPECT_TRUE(std::regex_match(r.out.substr(0, error), redraws)) << r.out;
  // The line comes back after the diagnostic and its notes, and is gone before the error count.
  EXPECT_NE(r.out.find("\rkiln: 3/3 stage sources (100%)", error), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("\r\033[Kkiln: 1 error(s), including internal compiler errors\n"), std::string::npos) << r.out;
}

TEST_F(Cli, EveryVerbHasHelp) {
  // The verbs as `kiln --help` lists them.
  auto top = testing::run_kiln({"--help"}, dir.path());
  EXPECT_EQ(top.exit_code, 0);
  std::vector<std::string> verbs;
  std::istringstream lines(top.out.substr(top.out.find("Subcommands:")));
  for (std::string line; std::getline(lines, line);)
    if (line.starts_with("  ") && line[2] != ' ') verbs.push_back(line.substr(2, line.find(' ', 2) - 2));
  EXPECT_EQ(verbs, (std::vector<std::string>{"build", "list", "inspect", "lint", "check-scene", "check-usage",
                                             "merge-usage", "diff-packs", "compile", "fold-cost", "watch", "render", "test"}));
  for (const std::string& verb : verbs) {
    auto r = testing::run_kiln({verb, "--help"}, dir.path());
    EXPECT_EQ(r.exit_code, 0) << verb;
    EXPECT_NE(r.out.find("Usage:"), std::string::npos) << verb;
    EXPECT_EQ(r.err, "") << verb;
  }
}

TEST_F(Cli, BadArgumentsAreUserErrorsWithExitCode1) {
  dir.write("S.hlsl", kEntries);
  const std::string hint = "Run with --help for more information.\n";
  struct Case {
    std::vector<std::string> args;
    std::string err;
  };
  for (const Case& c : std::vector<Case>{
           {{"biuld", "p.pack.json"}, "kiln: error: unknown command 'biuld'; did you mean 'build'?\n" + hint},
           {{}, "kiln: error: A subcommand is required\n" + hint},
           {{"build", "p.pack.json"}, "kiln: error: --output is required\n" + hint},
           {{"build", "p.pack.json", "-o", "out", "--bogus"},
            "kiln: error: The following argument was not expected: --bogus\n" + hint},
           {{"build", "p.pack.json", "-o", "out", "-j", "two"}, "kiln: error: Could not convert: --jobs = two\n" + hint},
           {{"build", "p.pack.json", "-o", "out", "--frontend", "dxc"},
            "kiln: error: --frontend: dxc not in {glslang}\n" + hint},
           {{"build", "missing.pack.json", "-o", "out"},
            "missing.pack.json: error[K1001]: cannot open 'missing.pack.json': No such file or directory\n"
            "kiln: 1 error(s)\n"},
           {{"build", "/dev/zero", "-o", "out"},
            "/dev/zero: error[K1002]: '/dev/zero' is a character device, not a regular file\n"
            "kiln: 1 error(s)\n"},
       }) {
    auto r = testing::run_kiln(c.args, dir.path());
    EXPECT_EQ(r.exit_code, 1) << c.err;
    EXPECT_EQ(r.err, c.err);
    EXPECT_EQ(r.out, "");
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "out"));
}

}  // namespace
}  // namespace kiln

namespace kiln {
namespace {

// K1406 (docs/bindings.md): once per root cause, at both HLSL declarations, naming the stages of the one
// variant that disagree, with the number of variants and the shift that fixes it.
// A layout clash is found after every variant compiled (their results are cached: each is valid alone);
// no pack is written.
void expect_layout_error(Cli& cli, const std::string& err) {
  auto r = cli.build();
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err, err);
  EXPECT_FALSE(std::filesystem::exists(cli.dir / "out/p.manifest.json"));
}

TEST_F(Cli, BindingClashBetweenTheStagesOfOneVariantIsReportedOnceAtBothDeclarations) {
  dir.write("S.hlsl",
            "#pragma multi_compile _ A\n"
            "cbuffer PerFrame : register(b0) { float4x4 viewProj; };\n"
            "Texture2D albedo : register(t0);\n"
            "SamplerState albedoSampler : register(s1);\n"
            "float4 V(float4 p : POSITION) : SV_Position { return mul(viewProj, p); }\n"
            "float4 F(float4 p : SV_Position) : SV_Target { return albedo.Sample(albedoSampler, p.xy); }\n");
  expect_layout_error(*this,
      "S.hlsl:2:9: error[K1406]: pass 'P': set 0 binding 0 holds 'PerFrame' (uniform_buffer) in the vertex stage and "
      "'albedo' (texture) in the fragment stage of the same variant, in 2 variants\n"
      "    cbuffer PerFrame : register(b0) { float4x4 viewProj; };\n"
      "            ^\n"
      "  note: first in variant [<none>]\n"
      "  note: registers of different classes share a number: shift one class, e.g. \"bindings\": {\"shifts\": "
      "[{\"register\": \"t\", \"shift\": 16, \"space\": 0}]} in the pack definition or --fvk-t-shift 16 0 (DXC's "
      "-fvk-t-shift), or give one of them [[vk::binding(N, 0)]]\n"
      "S.hlsl:3:11: note[K1406]: 'albedo' (texture) is declared here\n"
      "    Texture2D albedo : register(t0);\n"
      "              ^\n"
      "kiln: 1 error(s)\n");
  // The shift it suggests fixes it.
  EXPECT_EQ(build({"--fvk-t-shift", "16", "0"}).exit_code, 0);
}

TEST_F(Cli, BindingClashBetweenVariantsNamesEachSideWithItsVariants) {
  dir.write("S.hlsl",
            "#pragma multi_compile_fragment _ SWAP\n"
            "#ifdef SWAP\n"
            "Texture2D tex : register(t1);\n"
            "SamplerState smp : register(s2);\n"
            "#else\n"
            "cbuffer B : register(b1) { float4 x; };\n"
            "#endif\n"
            "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
            "#ifdef SWAP\nfloat4 F() : SV_Target { return tex.Sample(smp, float2(0.5, 0.5)); }\n"
            "#else\nfloat4 F() : SV_Target { return x; }\n#endif\n");
  expect_layout_error(*this,
      "S.hlsl:6:9: error[K1406]: pass 'P': set 0 binding 1 holds both 'B' (uniform_buffer) and 'tex' (texture), in "
      "different variants: 'B' (uniform_buffer) in 1 variant [<none>], 'tex' (texture) in 1 variant [SWAP]\n"
      "    cbuffer B : register(b1) { float4 x; };\n"
      "            ^\n"
      "  note: registers of different classes share a number: shift one class, e.g. \"bindings\": {\"shifts\": "
      "[{\"register\": \"t\", \"shift\": 16, \"space\": 0}]} in the pack definition or --fvk-t-shift 16 0 (DXC's "
      "-fvk-t-shift), or give one of them [[vk::binding(N, 0)]]\n"
      "S.hlsl:3:11: note[K1406]: 'tex' (texture) is declared here\n"
      "    Texture2D tex : register(t1);\n"
      "              ^\n"
      "kiln: 1 error(s)\n");
}

// An #ifdef before a resource without a register moves its automatic binding: one error, for the move.
TEST_F(Cli, AnAutomaticBindingMovedByAKeywordIsOneErrorAboutTheMove) {
  dir.write("S.hlsl",
            "#pragma multi_compile_fragment _ EXTRA\n#ifdef EXTRA\nTexture2D extra;\n#endif\nTexture2D albedo;\n"
            "SamplerState smp : register(s8);\n"
            "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
            "float4 F(float4 p : SV_Position) : SV_Target {\n  float4 c = albedo.Sample(smp, p.xy);\n"
            "#ifdef EXTRA\n  c += extra.Sample(smp, p.xy);\n#endif\n  return c;\n}\n");
  expect_layout_error(*this,
      "S.hlsl:5:11: error[K1406]: pass 'P': 'albedo' is at set 0 binding 0 in 1 variant [<none>] and at set 0 binding 1 in "
      "1 variant [EXTRA]\n"
      "    Texture2D albedo;\n"
      "              ^\n"
      "  note: a resource must have one binding in every variant of a pass; one declared without a register is "
      "bound automatically in declaration order, so a keyword that removes a declaration before it moves it: give it a "
      "register or [[vk::binding(N, S)]]\n"
      "kiln: 1 error(s)\n");
}

TEST_F(Cli, TextureAndSamplerAtOneRegisterNumberSuggestTheCombinedMode) {
  dir.write("S.hlsl", "Texture2D albedo : register(t1);\nSamplerState albedoSampler : register(s1);\n"
                      "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
                      "float4 F(float4 p : SV_Position) : SV_Target { return albedo.Sample(albedoSampler, p.xy); }\n");
  expect_layout_error(*this,
      "S.hlsl:1:11: error[K1406]: pass 'P': set 0 binding 1 holds both 'albedo' (texture) and 'albedoSampler' (sampler) "
      "in the fragment stage, in 1 variant\n"
      "    Texture2D albedo : register(t1);\n"
      "              ^\n"
      "  note: first in variant [<none>]\n"
      "  note: registers of different classes share a number: shift one class, e.g. \"bindings\": {\"shifts\": "
      "[{\"register\": \"s\", \"shift\": 16, \"space\": 0}]} in the pack definition or --fvk-s-shift 16 0 (DXC's "
      "-fvk-s-shift), or give one of them [[vk::binding(N, 0)]]; or, if the texture and the sampler are meant as one "
      "combined image sampler, set \"combined_image_samplers\": true (--combined-image-samplers)\n"
      "S.hlsl:2:14: note[K1406]: 'albedoSampler' (sampler) is declared here\n"
      "    SamplerState albedoSampler : register(s1);\n"
      "                 ^\n"
      "kiln: 1 error(s)\n");
  EXPECT_EQ(build({"--combined-image-samplers"}).exit_code, 0);
}

TEST_F(Cli, ASamplerSharedByTexturesCannotBeCombinedAndSaysWhy) {
  dir.write("S.hlsl", "Texture2D a : register(t0);\nTexture2D b : register(t1);\nSamplerState s : register(s0);\n"
                      "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
                      "float4 F(float4 p : SV_Position) : SV_Target { return a.Sample(s, p.xy) + b.Sample(s, p.xy); }\n");
  expect_build_error("S.hlsl: error[K1404]: combine-image-samplers: the texture and the sampler at set 0 binding 0 cannot "
                     "become one combined image sampler: the sampler also samples another texture, or the texture is "
                     "sampled with another sampler; give the sampler its own binding (an s shift)\n"
                     "  note: in pass 'P' fragment stage, keywords [<none>]\n"
                     "kiln: 1 error(s)\n",
                     {"--combined-image-samplers"});
}

TEST_F(Cli, ADefineThatIsNotAnIdentifierIsAClearError) {
  dir.write("S.hlsl", kEntries);
  expect_build_error("<command line>: error[K1014]: -D '2FAST=1': '2FAST' is not a preprocessor identifier: letters, "
                     "digits and '_', not starting with a digit (expected -D NAME or -D NAME=VALUE)\n",
                     {"-D", "LEVEL=2", "-D", "2FAST=1"});
  auto list = testing::run_kiln({"list", "p.pack.json", "-D", "A-B"}, dir.path());
  EXPECT_EQ(list.exit_code, 1);
  EXPECT_EQ(list.err, "<command line>: error[K1014]: -D 'A-B': 'A-B' is not a preprocessor identifier: letters, digits "
                      "and '_', not starting with a digit (expected -D NAME or -D NAME=VALUE)\n");
}

TEST_F(Cli, AKeywordKindThatIsNotKeywordsEqualsAKindIsAClearError) {
  dir.write("S.hlsl", std::string("#pragma multi_compile_fragment _ A\n") + kEntries);
  const std::string expected =
      "<command line>: error[K1014]: --keyword-kind '%': expected KEYWORD[,KEYWORD...]=KIND, the kind variant, "
      "dynamic_branch, specialization_constant or specialization_constant_int\n";
  for (const std::string text : {"A", "A=uniform", "=dynamic_branch", "A,=dynamic_branch", "A-B=dynamic_branch"})
    expect_build_error(std::regex_replace(expected, std::regex("%"), text), {"--keyword-kind", text});
  auto list = testing::run_kiln({"list", "p.pack.json", "--keyword-kind", "A=dynamic_branch"}, dir.path());
  EXPECT_EQ(list.exit_code, 0) << list.err;
}

// kiln fold-cost's plan from the command line: the table for people, the JSON for tools, nothing compiled.
TEST_F(Cli, FoldCostPlansEachGroupFoldedAloneWithoutCompiling) {
  dir.write("S.hlsl", std::string("#pragma multi_compile_fragment _ A B\n#pragma multi_compile_fragment _ C\n") + kEntries);
  auto r = testing::run_kiln({"fold-cost", "p.pack.json", "--json", "-"}, dir.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // Neither group's code tests KILN_FOLDED_: each is unsafe to fold, in those words, and the safe total leaves it out.
  EXPECT_NE(r.err.find("kiln fold-cost: pack 'p': 6 variants, 7 stage sources (planned: nothing preprocessed or compiled)\n"
                       "  A B [P]: unsafe to fold: no source tests KILN_FOLDED_A (or KILN_GROUP_OF_), so folded, its #if "
                       "defined() would hold for every value; folded alone it would be 3 (-57.1%) stage sources\n"),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("  all 0 that can be folded safely, folded: 7 (+0.0%) stage sources (2 unsafe to fold left out)\n"
                       "recommended \"keyword_kinds\" (paste into the pack definition; not measured at run time: "
                       "--render-scene draws each kind):\n  \"keyword_kinds\": {}\n"),
            std::string::npos)
      << r.err;
  const nlohmann::json plan = nlohmann::json::parse(r.out);
  EXPECT_EQ(plan["stage_sources"], 7);
  ASSERT_EQ(plan["candidates"].size(), 2u);
  EXPECT_EQ(plan["candidates"][1]["keywords"], nlohmann::json::array({"C"}));
  EXPECT_EQ(plan["candidates"][1]["stage_sources"], 4);
  EXPECT_EQ(plan["all_folded_stage_sources"], 7);
  EXPECT_EQ(plan["candidates"][1]["safe"], false);
  EXPECT_TRUE(plan["recommended_keyword_kinds"].empty());
  EXPECT_FALSE(std::filesystem::exists(dir / ".kiln-cache"));

  // Written for folding: safe, in the total, and in the block to paste (a group of two keywords: one int constant).
  dir.write("S.hlsl", std::string("#pragma multi_compile_fragment _ A B\n#pragma multi_compile_fragment _ C\n") +
                          "#if defined(KILN_FOLDED_A)\n#endif\n" + kEntries);
  r = testing::run_kiln({"fold-cost", "p.pack.json"}, dir.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("  A B [P]: folded alone, 3 (-57.1%) stage sources\n"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("  all 1 that can be folded safely, folded: 3 (-57.1%) stage sources (1 unsafe to fold left out)\n"
                       "recommended \"keyword_kinds\" (paste into the pack definition; not measured at run time: "
                       "--render-scene draws each kind):\n"
                       "  \"keyword_kinds\": {\n    \"A\": \"specialization_constant_int\",\n    \"B\": "
                       "\"specialization_constant_int\"\n  },\n"),
            std::string::npos)
      << r.out;

  // A shader_feature group the materials strip: folded, they would not, and the budget says no; the verb says why.
  dir.write("S.hlsl", std::string("#pragma shader_feature_fragment _ M\n#pragma multi_compile_fragment _ A B\n") + kEntries);
  dir.write("p.pack.json", R"({"name": "p", "budget": 3, "materials": [{"name": "plain"}],
      "passes": [{"name": "P", "source": "S.hlsl", "stages": {"vertex": "V", "fragment": "F"}}]})");
  r = testing::run_kiln({"fold-cost", "p.pack.json", "--fold", "M"}, dir.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("  M [P]: cannot be folded: folded, a shader_feature group is no longer stripped by the pack's materials "
                       "(every material's variants keep each of its values), so pack 'p' has more than 3 variants after "
                       "stripping"),
            std::string::npos)
      << r.out;
  dir.write("p.pack.json", kPack);
  auto unknown = testing::run_kiln({"fold-cost", "p.pack.json", "--fold", "D"}, dir.path());
  EXPECT_EQ(unknown.exit_code, 1);
  EXPECT_EQ(unknown.err, "<command line>: error[K1014]: --fold 'D': no pass declares keyword 'D'\n");
}

// The run-time half on the bundled library (docs/keywords.md "Choosing a kind"): the same Forward variants drawn from
// the pack built as variants and each folded kind, with a recommendation per keyword. Multiscatter's code is written
// for folding, and its folded images are the variant's; _LINEAR_OUTPUT's is not, so it is not drawn folded.
TEST_F(Cli, FoldCostDrawsTheFoldedPacksOnLavapipeAndRecommendsAKindPerKeyword) {
  const std::filesystem::path root = KILN_SOURCE_DIR;
  auto r = testing::run_kiln({"fold-cost", (root / "variants/lit.pack.json").string(), "--scene",
                              (root / "variants/scenes/outdoor_day.json").string(), "--fold", "_MULTISCATTER", "--fold",
                              "_LINEAR_OUTPUT", "--render-scene", (root / "variants/scenes/render/spheres.json").string(),
                              "--frames", "3", "--rounds", "1", "-j", "2", "--json", "-"},
                             dir.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("_LINEAR_OUTPUT [Forward]: unsafe to fold: no source tests KILN_FOLDED__LINEAR_OUTPUT"), std::string::npos)
      << r.err;
  // The block to paste holds what the draws accepted (or nothing, when they were too noisy to decide), never the
  // group that is unsafe to fold.
  EXPECT_NE(r.err.find("recommended \"keyword_kinds\" (paste into the pack definition):\n"), std::string::npos) << r.err;
  const nlohmann::json result = nlohmann::json::parse(r.out);
  const nlohmann::json& rows = result["frames"]["rows"];
  ASSERT_EQ(rows.size(), 2u) << rows.dump(1);
  EXPECT_EQ(rows[0]["name"], "all folded keywords off");
  EXPECT_EQ(rows[1]["name"], "_MULTISCATTER on");
  EXPECT_EQ(rows[1]["keywords"], nlohmann::json::array({"_MULTISCATTER"}));
  for (const nlohmann::json& row : rows) {
    for (const char* kind : {"dynamic_branch", "specialization_constant", "specialization_constant_int"}) {
      EXPECT_GT(row["draw_ms_median"][kind].get<double>(), 0) << kind;
      EXPECT_LE(row["largest_relative_difference"][kind].get<double>(), 1e-2) << kind << ": folding changed the image";
    }
    EXPECT_FALSE(row["recommendation"].get<std::string>().empty());
  }
  EXPECT_NE(r.err.find("_MULTISCATTER on: variant "), std::string::npos) << r.err;
  EXPECT_FALSE(result["recommended_keyword_kinds"].contains("_LINEAR_OUTPUT")) << result["recommended_keyword_kinds"];
}

// Numbers outside the double range aborted build, lint and list (an uncaught nlohmann out_of_range, exit 134),
// even in "description"; a repeated key was silently last-wins; 200,000 nested arrays are refused at 64 levels.
TEST_F(Cli, HostileJsonInAPackOrSceneIsALocatedError) {
  dir.write("S.hlsl", kEntries);
  const std::string pack_head = R"({"name": "p", "description": )";
  for (const std::string& number : {std::string("1e400"), std::string("-1e400"), std::string(1000000, '9')}) {
    dir.write("p.pack.json", pack_head + number + R"(, "passes": [{"name": "P", "source": "S.hlsl", "stages": {"vertex": "V", "fragment": "F"}}]})");
    const std::string shown = number.size() > 40 ? std::string(32, '9') + "...' (1000000 characters)\n" : number + "'\n";
    for (const std::string verb : {"build", "lint", "list"}) {
      auto r = testing::run_kiln(verb == "build" ? std::vector<std::string>{"build", "p.pack.json", "-o", "out"}
                                                 : std::vector<std::string>{verb, "p.pack.json"},
                                 dir.path());
      EXPECT_EQ(r.exit_code, 1) << verb << " " << number.size() << "\n" << r.err.substr(0, 300);
      // lint reports the build's errors under its build-error rule.
      const std::string id = verb == "lint" ? "build-error" : "K1010";
      EXPECT_EQ(r.err.rfind("p.pack.json:1:30: error[" + id + "]: invalid JSON: number overflow parsing '" + shown, 0), 0u)
          << verb << "\n" << r.err.substr(0, 300);
    }
  }
  dir.write("p.pack.json", kPack);
  dir.write("s.json", "{\"name\": \"s\",\n \"keywords\": [],\n \"name\": \"t\"}\n");
  auto twice = testing::run_kiln({"list", "p.pack.json", "--scene", "s.json"}, dir.path());
  EXPECT_EQ(twice.exit_code, 1);
  EXPECT_EQ(twice.err.rfind("s.json:3:7: error[K1010]: invalid JSON: the key \"name\" appears twice in one object", 0), 0u)
      << twice.err;
  dir.write("s.json", "{\"name\": \"s\", \"keywords\": " + std::string(200000, '[') + std::string(200000, ']') + "}");
  auto deep = testing::run_kiln({"list", "p.pack.json", "--scene", "s.json"}, dir.path());
  EXPECT_EQ(deep.exit_code, 1);
  EXPECT_EQ(deep.err.rfind("s.json:1:90: error[K1010]: invalid JSON: arrays and objects are nested more than 64 deep", 0), 0u)
      << deep.err.substr(0, 300);
}

// Thread groups glslang took and then mistranslated: numthreads(0,0,0) was an internal error, 2^32-1 an optimizer
// error with an internal message, 1024x1024x64 threads and 4 GiB of groupshared passed silently. Each is now the
// source's error (K1401) at its line, by D3D's limits, which DXC enforces.
TEST_F(Cli, ThreadGroupsBeyondTheLimitsAreTheSourcesErrors) {
  const struct {
    std::string source, err;
  } cases[] = {
      {"[numthreads(0,0,0)]\nvoid CS(uint3 id : SV_DispatchThreadID) { }\n",
       "C.hlsl:1:2: error[K1401]: numthreads(0, 0, 0): each dimension of a thread group must be at least 1\n"},
      {"[numthreads(4294967295,1,1)]\nvoid CS(uint3 id : SV_DispatchThreadID) { }\n",
       "C.hlsl:1:2: error[K1401]: numthreads(4294967295, 1, 1): a thread group is at most 1024 x 1024 x 64 (D3D's "
       "limits, which DXC enforces; Vulkan, GL and Metal guarantee no more)\n"},
      {"// a group\n[numthreads(1024,1024,64)]\nvoid CS(uint3 id : SV_DispatchThreadID) { }\n",
       "C.hlsl:2:2: error[K1401]: numthreads(1024, 1024, 64): 67108864 threads in a group, over the 1024 that D3D, "
       "Metal and DXC allow (Vulkan guarantees 128)\n"},
      {"#define N 0\n[numthreads(N * 2 + 8, 1, N)]\nvoid CS(uint3 id : SV_DispatchThreadID) { }\n",
       "C.hlsl:2:2: error[K1401]: numthreads(8, 1, 0): each dimension of a thread group must be at least 1\n"},
      {"groupshared float4 big[268435456];\n[numthreads(64,1,1)]\nvoid CS(uint3 id : SV_DispatchThreadID) { big[id.x] = 1; }\n",
       "C.hlsl:1:1: error[K1401]: groupshared variables take 4294967296 bytes, over the 32768 that D3D and DXC allow "
       "(Vulkan guarantees 16384)\n"},
  };
  dir.write("p.pack.json", R"({"name": "p", "passes": [{"name": "P", "source": "C.hlsl", "stages": {"compute": "CS"}}]})");
  for (const auto& c : cases) {
    dir.write("C.hlsl", c.source);
    auto r = build();
    EXPECT_EQ(r.exit_code, 1) << c.source << r.err;
    EXPECT_EQ(r.err.substr(0, r.err.find('\n') + 1), c.err) << r.err;
  }
  dir.write("C.hlsl", "groupshared float4 tile[2048];\n[numthreads(32,32,1)]\n"
                      "void CS(uint3 id : SV_DispatchThreadID) { tile[id.x] = 1; }\n");
  EXPECT_EQ(build().exit_code, 0) << "32 KiB of groupshared and 1024 threads are within the limits";
}

// glslang's preprocess-only mode, which kiln uses, rejected `#include "x"` on a last line without a newline
// ("expected newline after header name"); glslangValidator and glslc accept it, and so does kiln now, in the entry
// file and in included files.
TEST_F(Cli, AnIncludeOnALastLineWithoutANewlineBuilds) {
  dir.write("lib/Inc.hlsl", "#include \"Deeper.hlsl\"");
  dir.write("lib/Deeper.hlsl", "float Half(float x) { return x * 0.5; }");
  dir.write("lib/Tail.hlsl", "// nothing after this");
  dir.write("S.hlsl", "#include \"Inc.hlsl\"\nfloat4 V(float4 p : POSITION) : SV_Position { return p; }\n"
                      "float4 F() : SV_Target { return Half(1.0).xxxx; }\n#include \"Tail.hlsl\"");
  auto r = build();
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(std::filesystem::exists(dir / "out/p.manifest.json"));
}


// [[vk::...]] attributes that change the interface in DXC and that glslang 12 ignores with a warning: a pack built
// with them had another interface than the author wrote. Each is an error naming the attribute at its column
// ([[vk::offset]] is written into the layout, or is an error of its own: pipeline.HlslCompat.*Offset*).
TEST_F(Cli, VkAttributesGlslangWouldDropAreErrors) {
  const struct {
    const char* declaration;
    const char* attribute;
    int column;
  } cases[] = {
      {"[[vk::image_format(\"rgba8\")]] RWTexture2D<float4> img;\n", "image_format", 7},
      {"[[vk::combinedImageSampler]] Texture2D tex;\n", "combinedImageSampler", 7},
      {"[[vk::counter_binding(3)]] RWStructuredBuffer<float> items;\n", "counter_binding", 7},
  };
  for (const auto& c : cases) {
    dir.write("S.hlsl", std::string(c.declaration) + kEntries);
    auto r = build();
    EXPECT_EQ(r.exit_code, 1) << r.err;
    const std::string expected = "S.hlsl:1:" + std::to_string(c.column) + ": error[K1401]: '" + c.attribute +
                                 "' : [[vk::" + c.attribute + "]] changes the interface in DXC (it ";
    EXPECT_EQ(r.err.rfind(expected, 0), 0u) << r.err;
  }
  // An attribute glslang does not know that changes no interface stays a warning.
  dir.write("S.hlsl", std::string("[[vk::made_up]] float4 unused;\n") + kEntries);
  auto other = build();
  EXPECT_EQ(other.exit_code, 0) << other.err;
}


// [[vk::combinedImageSampler]]'s error never suggests the setting already in force: with combined image samplers off
// it names the setting; with them on, it says what pairs a texture and a sampler then (one binding).
TEST_F(Cli, TheCombinedImageSamplerAttributesAdviceIsNeverTheSettingAlreadyOn) {
  dir.write("S.hlsl", std::string("[[vk::combinedImageSampler]] Texture2D tex;\n") + kEntries);
  const std::string error = "S.hlsl:1:7: error[K1401]: 'combinedImageSampler' : [[vk::combinedImageSampler]] changes the "
                            "interface in DXC (it pairs a texture and a sampler into one combined image sampler); glslang 12 "
                            "ignores it, so the shader would be built with another interface: ";
  auto off = build();
  EXPECT_EQ(off.exit_code, 1) << off.err;
  EXPECT_EQ(off.err.substr(0, off.err.find('\n') + 1),
            error + "set \"bindings\": {\"combined_image_samplers\": true} (or --combined-image-samplers), which pairs a "
                    "texture and a sampler that share a register number\n")
      << off.err;
  auto on = build({"--combined-image-samplers"});
  EXPECT_EQ(on.exit_code, 1) << on.err;
  EXPECT_EQ(on.err.substr(0, on.err.find('\n') + 1),
            error + "combined image samplers are on, and they pair a texture and a sampler that share a binding: drop the "
                    "attribute and give the texture and its sampler one register number (tN and sN) or the same "
                    "[[vk::binding(N)]]\n")
      << on.err;
  EXPECT_EQ(on.err.find("combined_image_samplers\": true"), std::string::npos) << on.err;
}


// A define glslang's preamble cannot take was located in a file named "-1" (glslang's name for its preamble).
TEST_F(Cli, AnErrorInADefinesValueIsLocatedOnTheCommandLine) {
  dir.write("S.hlsl", "float4 V(float4 p : POSITION) : SV_Position { return p; }\nfloat4 F() : SV_Target { return X; }\n");
  auto r = build({"-D", "X=\""});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err.substr(0, r.err.find('\n') + 1),
            "<command line>: error[K1408]: 'string' : End of line in string (in a define: -D or the pack's \"defines\")\n")
      << r.err;
}


// `kiln inspect --extract` into a directory that cannot be made aborted (an uncaught filesystem_error, exit 134).
TEST_F(Cli, ExtractIntoADirectoryThatCannotBeMadeIsAnErrorNotAnAbort) {
  dir.write("S.hlsl", kEntries);
  ASSERT_EQ(build().exit_code, 0);
  dir.write("blocker", "a file where the directory would go");
  auto r = testing::run_kiln({"inspect", "out", "--extract", "blocker/sub"}, dir.path());
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_EQ(r.err.rfind("blocker/sub: error[K1601]: cannot create the --extract directory: ", 0), 0u) << r.err;
  auto over_file = testing::run_kiln({"inspect", "out", "--extract", "blocker"}, dir.path());
  EXPECT_EQ(over_file.exit_code, 3);
  EXPECT_EQ(over_file.err.rfind("blocker: error[K1601]: cannot create the --extract directory", 0), 0u) << over_file.err;
}

// One error model (diagnostics.def's exit classes): every verb that writes a file, given one it cannot write
// (under a regular file, so that root cannot write it either), names the path with K1601 and exits 3, the
// environment's status, and leaves nothing behind.
TEST_F(Cli, EveryVerbThatWritesAFileExitsThreeWithK1601WhenItCannot) {
  dir.write("S.hlsl", kEntries);
  ASSERT_EQ(build().exit_code, 0);
  {
    PackReader reader = PackReader::open(dir / "out");
    reader.record_usage({dir / "run.json", {}});
    reader.select("P", {});
  }
  dir.write("blocker", "a file where a directory would go");
  const std::vector<std::vector<std::string>> commands{
      {"build", "p.pack.json", "-o", "blocker/out", "--cache", "cache"},
      {"build", "p.pack.json", "-o", "out2", "--cache", "cache", "--summary-json", "blocker/summary.json"},
      {"build", "p.pack.json", "-o", "out3", "--cache", "cache", "--depfile", "blocker/pack.d"},
      {"build", "p.pack.json", "-o", "out4", "--cache", "cache", "--trace", "blocker/trace.json"},
      {"compile", "S.hlsl", "-S", "fragment", "-E", "F", "-o", "blocker/f.spv"},
      {"compile", "S.hlsl", "-S", "fragment", "-E", "F", "-o", "f.spv", "--depfile", "blocker/f.d"},
      {"lint", "p.pack.json", "--format", "sarif", "-o", "blocker/lint.sarif"},
      {"lint", "S.hlsl", "-o", "blocker/lint.txt"},
      {"inspect", "out", "--extract", "blocker/extracted"},
      {"merge-usage", "run.json", "-o", "blocker/merged.json"},
  };
  for (const auto& command : commands) {
    const auto r = testing::run_kiln(command, dir.path());
    std::string shown;
    for (const std::string& word : command) shown += word + " ";
    EXPECT_EQ(r.exit_code, 3) << shown << "\n" << r.err;
    EXPECT_NE(r.err.find("blocker"), std::string::npos) << shown << "\n" << r.err;
    EXPECT_NE(r.err.find("error[K1601]: "), std::string::npos) << shown << "\n" << r.err;
  }
  EXPECT_TRUE(std::filesystem::is_regular_file(dir / "blocker"));
}

// Every verb that writes a file writes it as glslc does when the path is a device: `-o /dev/null` checks a shader
// and leaves /dev/null what it was (root in a CI container used to get a regular file in its place), /dev/full is
// K1601 with exit 3, not success; and a link to a regular file is refused (K1601) with neither end changed. The
// devices are made in the test's directory (the machine's own only where a test may not make devices).
TEST_F(Cli, EveryVerbThatWritesAFileWritesADeviceInPlaceAndRefusesALink) {
  dir.write("S.hlsl", kEntries);
  ASSERT_EQ(build().exit_code, 0);
  {
    PackReader reader = PackReader::open(dir / "out");
    reader.record_usage({dir / "run.json", {}});
    reader.select("P", {});
  }
  auto device = [&](const char* name, unsigned minor) {
    const std::filesystem::path at = dir / name;
    return ::mknod(at.c_str(), S_IFCHR | 0666, makedev(1, minor)) == 0 ? at : std::filesystem::path("/dev") / name;
  };
  const std::filesystem::path null = device("null", 3), full = device("full", 7);
  dir.write("real.txt", "kept");
  std::filesystem::create_symlink("real.txt", dir / "link");
  const auto commands = [](const std::string& to) {
    return std::vector<std::vector<std::string>>{
        {"compile", "S.hlsl", "-S", "fragment", "-E", "F", "-o", to},
        {"compile", "S.hlsl", "-S", "fragment", "-E", "F", "-o", "f.spv", "--depfile", to},
        {"build", "p.pack.json", "-o", "out2", "--cache", "cache", "-q", "--summary-json", to},
        {"build", "p.pack.json", "-o", "out3", "--cache", "cache", "-q", "--depfile", to},
        {"build", "p.pack.json", "-o", "out4", "--cache", "cache", "-q", "--trace", to},
        {"lint", "p.pack.json", "--format", "sarif", "-o", to},
        {"lint", "S.hlsl", "--format", "json", "-o", to},
        {"merge-usage", "run.json", "-o", to},
    };
  };
  auto shown = [](const std::vector<std::string>& command) {
    std::string text;
    for (const std::string& word : command) text += word + " ";
    return text;
  };
  for (const auto& command : commands(null.string())) {
    const auto r = testing::run_kiln(command, dir.path());
    EXPECT_EQ(r.exit_code, 0) << shown(command) << "\n" << r.err;
    struct stat info {};
    ASSERT_EQ(::lstat(null.c_str(), &info), 0);
    EXPECT_TRUE(S_ISCHR(info.st_mode)) << shown(command) << " replaced the device";
  }
  for (const auto& command : commands(full.string())) {
    const auto r = testing::run_kiln(command, dir.path());
    EXPECT_EQ(r.exit_code, 3) << shown(command) << "\n" << r.err;
    EXPECT_NE(r.err.find("error[K1601]: "), std::string::npos) << shown(command) << "\n" << r.err;
    EXPECT_NE(r.err.find("No space left"), std::string::npos) << shown(command) << "\n" << r.err;
  }
  for (const auto& command : commands("link")) {
    const auto r = testing::run_kiln(command, dir.path());
    EXPECT_EQ(r.exit_code, 3) << shown(command) << "\n" << r.err;
    EXPECT_NE(r.err.find("error[K1601]: "), std::string::npos) << shown(command) << "\n" << r.err;
    EXPECT_NE(r.err.find("symbolic link"), std::string::npos) << shown(command) << "\n" << r.err;
    EXPECT_TRUE(std::filesystem::is_symlink(dir / "link")) << shown(command);
    EXPECT_EQ(testing::read_file(dir / "real.txt"), "kept") << shown(command);
  }
}

// One guarded entry point: an exception that escapes any verb of kiln or kiln-verify, whatever its type, is reported
// as a bug in kiln with exit 2 (never an abort, never 1 as if the input were at fault). The test builds of both
// executables (tests/support/fault_injection.hpp) throw it inside the verb once its arguments are parsed.
TEST_F(Cli, AnExceptionThatEscapesAnyVerbIsABugInKilnWithExitTwo) {
  dir.write("S.hlsl", kEntries);
  ASSERT_EQ(build().exit_code, 0);
  {
    PackReader reader = PackReader::open(dir / "out");
    reader.record_usage({dir / "run.json", {}});
    reader.select("P", {});
  }
  const std::map<std::string, std::vector<std::string>> verbs{
      {"build", {"p.pack.json", "-o", "out2", "--cache", "cache"}},
      {"list", {"p.pack.json"}},
      {"inspect", {"out"}},
      {"lint", {"p.pack.json"}},
      {"check-scene", {"out", "p.pack.json"}},
      {"check-usage", {"out", "run.json"}},
      {"merge-usage", {"run.json", "-o", "merged.json"}},
      {"diff-packs", {"out", "out"}},
      {"compile", {"S.hlsl", "-S", "fragment", "-E", "F", "-o", "f.spv"}},
      {"fold-cost", {"p.pack.json"}},
      {"watch", {"p.pack.json", "-o", "out3", "--cache", "cache"}},
      {"render", {"out", "--scene", "p.pack.json", "-o", "x.png"}},
      {"test", {"out", "--scene", "p.pack.json", "--golden", "golden", "--tolerances", "p.pack.json"}},
  };
  for (const auto& [verb, args] : verbs) {
    for (const std::string kind : {"runtime_error", "filesystem_error", "bad_alloc", "unknown"}) {
      std::vector<std::string> command{"/usr/bin/env", "KILN_INJECT_FAULT=" + verb + ":" + kind,
                                       std::string("KILN_VERIFY=") + KILN_VERIFY_FAULT_PATH, KILN_FAULT_CLI_PATH, verb};
      command.insert(command.end(), args.begin(), args.end());
      const auto r = testing::run(command, dir.path());
      const std::string shown = verb + " (" + kind + ")\n" + r.err;
      EXPECT_EQ(r.exit_code, 2) << shown;
      if (kind == "bad_alloc") {
        EXPECT_EQ(r.err, "kiln: error: out of memory\n") << shown;
        continue;
      }
      EXPECT_EQ(r.err.rfind("kiln: internal error: ", 0), 0u) << shown;
      EXPECT_NE(r.err.find("note: this is a bug in kiln, not in your input"), std::string::npos) << shown;
      if (kind != "unknown") {
        EXPECT_NE(r.err.find("injected into '" + verb + "'"), std::string::npos) << shown;
      }
    }
  }
  // The shipped executables have no fault injection.
  const auto shipped = testing::run({"/usr/bin/env", "KILN_INJECT_FAULT=list:runtime_error", KILN_CLI_PATH, "list", "p.pack.json"},
                                    dir.path());
  EXPECT_EQ(shipped.exit_code, 0) << shipped.err;
}

// kiln render and kiln test report their errors as kiln does, with IDs of the same table (K20xx), a location, and
// the exit status of the error's class: the input's fault 1, the machine's 3.
TEST_F(Cli, RenderAndTestReportTheirErrorsWithIdsAndTheExitStatusOfTheirClass) {
  dir.write("S.hlsl", kEntries);
  ASSERT_EQ(build().exit_code, 0);
  const std::string scenes = std::string(KILN_SOURCE_DIR) + "/variants/scenes/render/";
  const std::string tolerances = scenes + "tolerances.json";
  dir.write("broken.json", "{\n  \"render\": {,\n}\n");
  dir.write("tolerances.json", "{\"classes\": [{\"name\": \"x\"}]}\n");
  std::filesystem::create_directories(dir / "golden");
  struct Case {
    std::vector<std::string> args;
    std::vector<std::string> environment;
    int exit_code;
    std::string expected;  // the start of stderr
  };
  const std::vector<Case> cases{
      {{"render", "out", "--scene", "broken.json", "-o", "x.png"}, {}, 1, "broken.json:2:14: error[K2001]: invalid JSON: "},
      {{"test", "out", "--scene", scenes + "spheres.json", "--golden", "golden", "--tolerances", "tolerances.json"}, {}, 1,
       "tolerances.json: error[K2002]: a tolerance class is malformed: "},
      {{"test", "out", "--scene", scenes + "spheres.json", "--golden", "golden", "--tolerances", tolerances}, {}, 1,
       "golden/index.json: error[K2003]: no golden index (make one with kiln-reference goldens)\n"},
      {{"render", "nowhere", "--scene", scenes + "spheres.json", "-o", "x.png"}, {}, 1, "nowhere: error[K2004]: "},
      {{"render", "out", "--scene", scenes + "spheres.json", "-o", "x.png", "--size", "big"}, {}, 1,
       "kiln: error[K2005]: --size wants WxH, e.g. 256x256 (got 'big')\n"},
      {{"test", "out", "--scene", scenes + "spheres.json", "--golden", "golden", "--tolerances", tolerances, "--shard", "2/2"},
       {},
       1,
       "kiln: error[K2005]: --shard wants I/N with I < N (got '2/2')\n"},
      // No Vulkan driver at all: the machine's fault, not the pack's.
      {{"render", "out", "--scene", scenes + "spheres.json", "-o", "x.png"},
       {"VK_ICD_FILENAMES=" + (dir / "none.json").string(), "VK_DRIVER_FILES=" + (dir / "none.json").string()},
       3,
       "kiln: error[K2006]: "},
  };
  for (const Case& c : cases) {
    std::vector<std::string> command{"/usr/bin/env"};
    command.insert(command.end(), c.environment.begin(), c.environment.end());
    command.push_back(KILN_CLI_PATH);
    command.insert(command.end(), c.args.begin(), c.args.end());
    const auto r = testing::run(command, dir.path());
    EXPECT_EQ(r.exit_code, c.exit_code) << c.args[0] << " " << c.args[1] << "\n" << r.err;
    EXPECT_EQ(r.err.substr(0, c.expected.size()), c.expected) << r.err;
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "x.png"));
}

// kiln-reference's outputs, as kiln's: one that cannot be written is K1601, exit 3.
TEST_F(Cli, KilnReferenceReportsAnUnwritableOutputAsKilnDoes) {
  dir.write("blocker", "a file where a directory would go");
  const auto r = testing::run({KILN_REFERENCE_PATH, "dfg", "--size", "2", "--samples", "1", "-o", "blocker/dfg.kdfg"},
                              dir.path());
  EXPECT_EQ(r.exit_code, 3) << r.err;
  EXPECT_EQ(r.err.rfind("blocker/dfg.kdfg: error[K1601]: cannot write 'blocker/dfg.kdfg': Not a directory", 0), 0u) << r.err;
  EXPECT_TRUE(std::filesystem::is_regular_file(dir / "blocker"));
}

// A pass name became a path: `--emit` wrote outside -o and an internal error's reproducer overwrote a file of
// that name anywhere. Pack, pass and scene names follow one rule (name_problem), for build and lint alike.
TEST_F(Cli, NamesThatWouldBecomePathsOutsideTheOutputAreRefused) {
  dir.write("S.hlsl", kEntries);
  for (const std::string& name : {std::string("../../x"), std::string("/tmp/x"), std::string(".."), std::string("")}) {
    dir.write("p.pack.json", R"({"name": "p", "passes": [{"name": )" + nlohmann::json(name).dump() +
                                 R"(, "source": "S.hlsl", "stages": {"vertex": "V", "fragment": "F"}}]})");
    for (const char* verb : {"build", "lint"}) {
      std::vector<std::string> args{verb, "p.pack.json"};
      if (std::string(verb) == "build") args.insert(args.end(), {"-o", "out", "--emit", "preprocessed"});
      auto r = testing::run_kiln(args, dir.path());
      EXPECT_EQ(r.exit_code, 1) << verb << " " << name << "\n" << r.err;
      // build: K1011; lint reports the build's errors under its build-error rule.
      EXPECT_NE(r.err.find("]: pass name '" + name + "' "), std::string::npos) << r.err;
    }
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "x"));
  EXPECT_FALSE(std::filesystem::exists("/tmp/x/vertex"));
  dir.write("p.pack.json", R"({"name": "", "passes": [{"name": "P", "source": "S.hlsl", "stages": {"vertex": "V", "fragment": "F"}}]})");
  auto unnamed = build();
  EXPECT_EQ(unnamed.exit_code, 1);
  EXPECT_NE(unnamed.err.find("error[K1011]: pack name '' is empty"), std::string::npos) << unnamed.err;
}

// `-D DIR=C:\shaders\` would end the preamble's #define with a line continuation and swallow the line after it
// (before the fix: exit 0 and different code). Refused on the command line and in the pack alike.
TEST_F(Cli, ADefineValueEndingInABackslashIsRefused) {
  dir.write("S.hlsl", kEntries);
  expect_build_error("<command line>: error[K1014]: -D 'DIR=C:\\shaders\\': the value of 'DIR' ends in a backslash, "
                     "which would continue the #define onto the next line and swallow it (expected -D NAME or -D "
                     "NAME=VALUE)\n",
                     {"-D", "DIR=C:\\shaders\\"});
  auto tab = testing::run_kiln({"list", "p.pack.json", "-D", "A=1\x01"}, dir.path());
  EXPECT_EQ(tab.exit_code, 1);
  EXPECT_NE(tab.err.find("the value of 'A' holds a line break or another control character"), std::string::npos) << tab.err;
}

TEST_F(Cli, AMalformedShiftIsAClearError) {
  dir.write("S.hlsl", kEntries);
  expect_build_error("<command line>: error[K1014]: --fvk-t-shift 16 space1: expected a shift and a register space, both "
                     "non-negative integers (the space may be 'all')\n",
                     {"--fvk-t-shift", "16", "space1"});
}

TEST_F(Cli, InspectShowsThePassBindingOptionsDefinesAndLayout) {
  dir.write("S.hlsl", "cbuffer PerFrame : register(b0) { float4 tint; };\nTexture2D albedo : register(t0);\n"
                      "SamplerState albedoSampler : register(s0);\n"
                      "float4 V(float4 p : POSITION) : SV_Position { return p + tint; }\n"
                      "float4 F(float4 p : SV_Position) : SV_Target { return albedo.Sample(albedoSampler, p.xy); }\n");
  ASSERT_EQ(build({"--fvk-t-shift", "16", "all", "--fvk-s-shift", "32", "0", "-D", "QUALITY=2"}).exit_code, 0);
  auto r = testing::run_kiln({"inspect", "out"}, dir.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("  pass P: 1 variants\n"
                       "    bindings: -fvk-t-shift 16 all -fvk-s-shift 32 0\n"
                       "    defines: {\"QUALITY\":\"2\"}\n"
                       "    set 0 binding 0: PerFrame (uniform_buffer)\n"
                       "    set 0 binding 16: albedo (texture)\n"
                       "    set 0 binding 32: albedoSampler (sampler)\n"),
            std::string::npos)
      << r.out;
}

TEST_F(Cli, ListJsonShowsTheBindingOptionsAndDefinesOfEachPass) {
  dir.write("S.hlsl", kEntries);
  dir.write("p.pack.json", R"({"name": "p", "bindings": {"shifts": [{"register": "t", "shift": 16}]}, "defines": {"Q": 1},
    "passes": [{"name": "P", "source": "S.hlsl", "stages": {"vertex": "V", "fragment": "F"},
                "bindings": {"combined_image_samplers": true}}]})");
  auto r = testing::run_kiln({"list", "p.pack.json", "--json", "-D", "Q=3", "-D", "R", "--fvk-s-shift", "32", "1"}, dir.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  auto passes = nlohmann::json::parse(r.out)["passes"];
  ASSERT_EQ(passes.size(), 1u);
  EXPECT_EQ(passes[0]["bindings"], "-fvk-t-shift 16 all -fvk-s-shift 32 1 -combined-image-samplers");
  EXPECT_EQ(passes[0]["defines"], nlohmann::json({{"Q", "3"}, {"R", "1"}}));
}

TEST_F(Cli, ListJsonShowsTheKeywordsEachStageSees) {
  dir.write("S.hlsl", std::string("#pragma multi_compile _ A\n#pragma multi_compile_fragment _ B\n") + kEntries);
  auto r = testing::run_kiln({"list", "p.pack.json", "--json"}, dir.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  auto listing = nlohmann::json::parse(r.out);
  ASSERT_EQ(listing["variants"].size(), 4u);
  EXPECT_EQ(listing["variants"][3]["keywords"], nlohmann::json::array({"A", "B"}));
  EXPECT_EQ(listing["variants"][3]["stages"]["vertex"], nlohmann::json::array({"A"}));
  EXPECT_EQ(listing["variants"][3]["stages"]["fragment"], nlohmann::json::array({"A", "B"}));
}

TEST_F(Cli, InspectExtractWritesEveryBlobWithItsTargetExtension) {
  dir.write("S.hlsl", kEntries);
  ASSERT_EQ(build().exit_code, 0);
  auto r = testing::run_kiln({"inspect", "out", "--extract", "blobs"}, dir.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("pass P: 1 variants"), std::string::npos) << r.out;
  const std::string archive = testing::archive_named_by(dir / "out/p.manifest.json").filename().string();
  EXPECT_NE(r.out.find(" bytes in " + archive + "\n"), std::string::npos) << r.out;
  for (const char* name : {"binary0.vertex.spv", "binary0.vertex.glsl", "binary0.vertex.es.glsl", "binary0.vertex.metal",
                           "binary1.fragment.spv"})
    EXPECT_TRUE(std::filesystem::exists(dir / "blobs" / name)) << name;
  std::string spirv = testing::read_file(dir / "blobs/binary1.fragment.spv");
  ASSERT_GE(spirv.size(), 4u);
  EXPECT_EQ(static_cast<unsigned char>(spirv[0]), 0x03);  // SPIR-V magic 0x07230203, little-endian
  EXPECT_EQ(static_cast<unsigned char>(spirv[3]), 0x07);
}

TEST_F(Cli, InspectOfACorruptPackIsAClearError) {
  dir.write("S.hlsl", kEntries);
  ASSERT_EQ(build().exit_code, 0);
  const std::string archive_file = testing::archive_named_by(dir / "out/p.manifest.json").filename().string();
  std::string archive = testing::read_file(dir / "out" / archive_file);
  archive[archive.size() / 2] ^= 0x10;
  dir.write("out/" + archive_file, archive);
  auto r = testing::run_kiln({"inspect", "out"}, dir.path());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err, "out/" + archive_file + ": error: archive of pack 'p' fails its checksum\n");
}

// Each error names the file it is in, and the line and column of a JSON syntax error.
TEST_F(Cli, InspectNamesTheFileOfEachPackError) {
  dir.write("S.hlsl", kEntries);
  ASSERT_EQ(build().exit_code, 0);
  const std::string manifest = testing::read_file(dir / "out/p.manifest.json");
  const std::string archive_hash = nlohmann::json::parse(manifest).at("archive").at("xxh3_64").get<std::string>();
  auto replaced = [&](const std::string& from, const std::string& to) {
    std::string text = manifest;
    size_t at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    return at == std::string::npos ? text : text.replace(at, from.size(), to);
  };
  auto replaced_all = [&](const std::string& from, const std::string& to) {
    std::string text = manifest;
    for (size_t at = text.find(from); at != std::string::npos; at = text.find(from, at + to.size())) text.replace(at, from.size(), to);
    return text;
  };
  struct Case {
    std::string manifest;
    std::string err;
  };
  const Case cases[] = {
      // The checksum is looked at before the text is parsed: anything without one is not a kiln manifest.
      {"{\n  \"format\": \"kiln-pack-manifest\",\n}\n",
       "out/p.manifest.json: error: not a kiln pack manifest: it has no checksum (\"manifest_xxh3_64\")\n"},
      {"[]", "out/p.manifest.json: error: not a kiln pack manifest: it has no checksum (\"manifest_xxh3_64\")\n"},
      {testing::resealed_manifest(replaced("\"format\": \"kiln-pack-manifest\",", "\"format\": \"kiln-pack-manifest\",,")),
       "out/p.manifest.json:33:33: error: not a kiln manifest: invalid JSON: syntax error while parsing object key - "
       "unexpected ','; expected string literal\n"},
      {testing::resealed_manifest(replaced("\"format\": \"kiln-pack-manifest\"", "\"format\": \"other\"")),
       "out/p.manifest.json: error: not a kiln pack manifest (no \"format\": \"kiln-pack-manifest\")\n"},
      {testing::resealed_manifest(replaced("\"format_version\": 5", "\"format_version\": 7")),
       "out/p.manifest.json: error: pack format version 7 is not supported (this reader reads version 5): rebuild the "
       "pack with this version of kiln\n"},
      {testing::resealed_manifest(replaced("\"format_version\": 5", "\"format_revision\": 5")),
       "out/p.manifest.json: error: the manifest has no format_version (this reader reads version 5): rebuild the pack "
       "with this version of kiln\n"},
      {testing::resealed_manifest(replaced("\"format_version\": 5", "\"format_version\": 5, \"format_version\": 5")),
       "out/p.manifest.json:34:38: error: not a kiln manifest: invalid JSON: the key \"format_version\" appears twice in "
       "one object (JSON does not say which one counts)\n"},
      // Valid JSON, edited: the manifest's own checksum refuses it.
      {replaced("\"reflection\": 0", "\"reflection\": 1"),
       "out/p.manifest.json: error: the manifest fails its checksum (changed since kiln wrote it)\n"},
      {replaced("\"manifest_xxh3_64\"", "\"manifest_checksum\""),
       "out/p.manifest.json: error: not a kiln pack manifest: it has no checksum (\"manifest_xxh3_64\")\n"},
      // Edited and resealed: the checks behind the checksum.
      {testing::resealed_manifest(replaced("\"name\": \"p\"", "\"title\": \"p\"")),
       "out/p.manifest.json: error: malformed manifest: top level: has no \"name\"\n"},
      // A hostile manifest names a file outside the pack: refused before any file is opened.
      {testing::resealed_manifest(replaced("\"file\": \"p.", "\"file\": \"../p.")),
       "out/p.manifest.json: error: malformed manifest: /archive/file: \"../p." + archive_hash +
           ".kpack\" is not the archive's name, <name>.<xxh3_64>.kpack\n"},
      {testing::resealed_manifest(replaced("\"file\": \"p." + archive_hash + ".kpack\"", "\"file\": \"/etc/passwd\"")),
       "out/p.manifest.json: error: malformed manifest: /archive/file: \"/etc/passwd\" is not the archive's name, "
       "<name>.<xxh3_64>.kpack\n"},
      {testing::resealed_manifest(replaced("\"name\": \"p\"", "\"name\": \"../p\"")),
       "out/p.manifest.json: error: malformed manifest: /name: \"../p\" is not a pack name: it may only use letters, digits, '_', '-' and '.'\n"},
      // A well-formed name whose archive is missing.
      {testing::resealed_manifest(replaced_all(archive_hash, "0123456789abcdef")),
       "out/p.0123456789abcdef.kpack: error: no such file or directory\n"},
      {testing::resealed_manifest(replaced("\"reflection\": 0", "\"reflection\": 9")),
       "out/p.manifest.json: error: malformed manifest: /binaries/0/reflection: index 9 is out of range (2 reflections)\n"},
      {testing::resealed_manifest(replaced("\"reflections\":", "\"reflexions\":")),
       "out/p.manifest.json: error: malformed manifest: top level: has no \"reflections\"\n"},
  };
  for (const Case& c : cases) {
    dir.write("out/p.manifest.json", c.manifest);
    auto r = testing::run_kiln({"inspect", "out"}, dir.path());
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_EQ(r.err, c.err);
  }
  auto missing = testing::run_kiln({"inspect", "no-such-pack"}, dir.path());
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_EQ(missing.err, "no-such-pack: error: no such file or directory\n");
  std::filesystem::create_directory(dir / "empty");
  auto empty = testing::run_kiln({"inspect", "empty"}, dir.path());
  EXPECT_EQ(empty.exit_code, 1);
  EXPECT_EQ(empty.err, "empty: error: the directory holds 0 pack manifests (*.manifest.json); name the manifest file\n");
  // diff-packs names the file too.
  dir.write("out/p.manifest.json", "{");
  auto diff = testing::run_kiln({"diff-packs", "out", "out"}, dir.path());
  EXPECT_EQ(diff.exit_code, 1);
  EXPECT_EQ(diff.err.rfind("out/p.manifest.json: error: not a kiln pack manifest: it has no checksum", 0), 0u) << diff.err;
}

TEST_F(Cli, UnwritableCacheIsAWarningAndThePackIsStillWritten) {
  dir.write("S.hlsl", kEntries);
  dir.write("cache", "a file where the cache directory should be\n");
  auto r = build();
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err.rfind("cache: warning[K1603]: cannot create the cache directory 'cache': ", 0), 0u) << r.err;
  EXPECT_NE(r.err.find("  note: the outputs are unaffected; the next build compiles these variants again\n"), std::string::npos)
      << r.err;
  EXPECT_TRUE(std::filesystem::exists(dir / "out/p.manifest.json"));
  EXPECT_EQ(testing::read_file(dir / "cache"), "a file where the cache directory should be\n");
}

TEST_F(Cli, ConcurrentBuildsSharingOneCacheAgreeByteForByte) {
  std::string pragmas;
  for (int i = 0; i < 4; ++i) pragmas += "#pragma multi_compile_fragment _ K" + std::to_string(i) + "\n";
  dir.write("S.hlsl", pragmas + "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
                                "float4 F() : SV_Target { float c = 0.1;\n"
                                "#ifdef K0\n c *= 2.0;\n#endif\n#ifdef K1\n c += 0.3;\n#endif\n"
                                "#ifdef K2\n c = sqrt(c);\n#endif\n#ifdef K3\n c = c * c;\n#endif\n return c; }\n");
  auto a = std::async(std::launch::async, [&] {
    return testing::run_kiln({"build", "p.pack.json", "-o", "outA", "--cache", "shared", "-q"}, dir.path());
  });
  auto b = std::async(std::launch::async, [&] {
    return testing::run_kiln({"build", "p.pack.json", "-o", "outB", "--cache", "shared", "-q"}, dir.path());
  });
  auto ra = a.get(), rb = b.get();
  ASSERT_EQ(ra.exit_code, 0) << ra.err;
  ASSERT_EQ(rb.exit_code, 0) << rb.err;
  EXPECT_EQ(testing::read_archive(dir / "outA/p.manifest.json"), testing::read_archive(dir / "outB/p.manifest.json"));
  EXPECT_EQ(testing::read_file(dir / "outA/p.manifest.json"), testing::read_file(dir / "outB/p.manifest.json"));
  // No temporary files are left in the shared cache.
  for (const auto& file : testing::files_below(dir / "shared"))
    EXPECT_EQ(file.filename().string().find(".tmp."), std::string::npos) << file;
}

}  // namespace
}  // namespace kiln

namespace kiln {
namespace {

TEST_F(Cli, CheckSceneFindsVariantsTheSceneNeedsButThePackLacks) {
  dir.write("S.hlsl", std::string("#pragma multi_compile _ A\n#pragma multi_compile_fragment _ B\n") + kEntries);
  dir.write("a.json", R"({"name": "a", "keywords": ["A"]})");
  dir.write("ab.json", R"({"name": "ab", "keywords": ["A", "B"]})");
  ASSERT_EQ(build({"--scene", "a.json"}).exit_code, 0);
  auto ok = testing::run_kiln({"check-scene", "out", "a.json"}, dir.path());
  EXPECT_EQ(ok.exit_code, 0) << ok.out << ok.err;
  EXPECT_EQ(ok.out, "kiln check-scene: 2 combinations the scene can request, 0 missing\n");
  auto missing = testing::run_kiln({"check-scene", "out", "ab.json"}, dir.path());
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_EQ(missing.out,
            "ab.json: error: pass 'P' variant [B] can be requested by the scene but is not in pack 'p'\n"
            "ab.json: error: pass 'P' variant [A B] can be requested by the scene but is not in pack 'p'\n"
            "kiln check-scene: 4 combinations the scene can request, 2 missing\n");
}

TEST_F(Cli, DiffPacksShowsAddedRemovedAndChangedVariants) {
  dir.write("S.hlsl", std::string("#pragma multi_compile _ A\n#pragma multi_compile_fragment _ B\n") + kEntries);
  dir.write("a.json", R"({"name": "a", "keywords": ["A"]})");
  dir.write("b.json", R"({"name": "b", "keywords": ["B"]})");
  ASSERT_EQ(build({"--scene", "a.json"}).exit_code, 0);
  std::filesystem::rename(dir / "out", dir / "old");
  dir.write("S.hlsl", std::string("#pragma multi_compile _ A\n#pragma multi_compile_fragment _ B\n") +
                          "float4 V(float4 p : POSITION) : SV_Position { return p * 2.0; }\nfloat4 F() : SV_Target { return 1.0; }\n");
  ASSERT_EQ(build({"--scene", "b.json"}).exit_code, 0);
  auto r = testing::run_kiln({"diff-packs", "old", "out"}, dir.path());
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out, "- P [A]\n+ P [B]\n~ P [<none>]\n1 added, 1 removed, 1 changed\n");
}

// The note of a binding clash points at the resource's declaration, not at its first use: here the entry file
// uses `albedo` before the include that declares it is read.
TEST_F(Cli, TheDeclaredHereNoteFindsTheDeclarationNotAUse) {
  dir.write("S.hlsl", "#include \"Resources.hlsl\"\n"
                      "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
                      "float4 F(float2 uv : TEXCOORD0) : SV_Target { return albedo.Sample(linearClamp, uv) * tint; }\n");
  dir.write("Resources.hlsl", "#pragma once\n"
                              "// albedo: the base colour\n"
                              "cbuffer Material : register(b0) { float4 tint; };\n"
                              "Texture2D albedo : register(t0);\n"
                              "SamplerState linearClamp : register(s1);\n");
  auto r = build();
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("Resources.hlsl:4:11: note[K1406]: 'albedo' (texture) is declared here"), std::string::npos) << r.err;
}

// kiln compile: one file, one stage, as glslc and DXC users first write it. The target follows the output's
// extension, -D selects a keyword's variant, -o - writes to standard output, the depfile names the output, and
// the diagnostics are the build's (a pack-level one is about the command line).
TEST_F(Cli, CompileBuildsOneFileForOneStageAsGlslcDoes) {
  dir.write("inc/Fog.hlsli", "float4 Fog(float4 c) { return c * 0.5; }\n");
  dir.write("x.hlsl", "#pragma multi_compile _ FOG\n#include \"Fog.hlsli\"\n"
                      "cbuffer Tint : register(b0) { float4 tint; };\n"
                      "float4 main(float2 uv : TEXCOORD0) : SV_Target {\n#ifdef FOG\n  return Fog(tint);\n#else\n  return tint;\n"
                      "#endif\n}\n");
  auto plain = testing::run_kiln({"compile", "x.hlsl", "-S", "frag", "-I", "inc", "-o", "x.spv"}, dir.path());
  ASSERT_EQ(plain.exit_code, 0) << plain.err;
  EXPECT_EQ(plain.err, "");
  const std::string spirv = testing::read_file(dir / "x.spv");
  ASSERT_GE(spirv.size(), 20u);
  EXPECT_EQ(spirv.substr(0, 4), std::string("\x03\x02\x23\x07", 4));  // SPIR-V's magic number
  auto fog = testing::run_kiln({"compile", "x.hlsl", "-S", "fragment", "-I", "inc", "-D", "FOG", "-o", "fog.spv", "--depfile", "fog.d"},
                               dir.path());
  ASSERT_EQ(fog.exit_code, 0) << fog.err;
  EXPECT_NE(testing::read_file(dir / "fog.spv"), spirv);  // the FOG variant
  const std::string depfile = testing::read_file(dir / "fog.d");
  EXPECT_TRUE(depfile.starts_with("fog.spv:")) << depfile;
  EXPECT_NE(depfile.find("Fog.hlsli"), std::string::npos) << depfile;
  EXPECT_EQ(depfile.find("compile.pack.json"), std::string::npos) << depfile;  // the scratch pack is no input
  auto glsl = testing::run_kiln({"compile", "x.hlsl", "-S", "frag", "-I", "inc", "-o", "x.frag"}, dir.path());
  ASSERT_EQ(glsl.exit_code, 0) << glsl.err;
  EXPECT_TRUE(testing::read_file(dir / "x.frag").starts_with("#version 450")) << testing::read_file(dir / "x.frag");
  auto msl = testing::run_kiln({"compile", "x.hlsl", "-S", "frag", "-I", "inc", "--target", "msl", "-o", "-"}, dir.path());
  ASSERT_EQ(msl.exit_code, 0) << msl.err;
  EXPECT_TRUE(msl.out.starts_with("#include <metal_stdlib>")) << msl.out;
  EXPECT_FALSE(std::filesystem::exists(dir / "-"));

  auto missing_entry = testing::run_kiln({"compile", "x.hlsl", "-S", "frag", "-E", "PSMain", "-I", "inc", "-o", "y.spv"}, dir.path());
  EXPECT_EQ(missing_entry.exit_code, 1);
  EXPECT_TRUE(missing_entry.err.starts_with("<command line>: error[K1402]: entry point 'PSMain' of the fragment stage is not defined"))
      << missing_entry.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "y.spv"));
  dir.write("bad.hlsl", "float4 main() : SV_Target {\n  return 1.0\n}\n");
  auto bad = testing::run_kiln({"compile", "bad.hlsl", "-S", "frag", "-o", "bad.spv"}, dir.path());
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_TRUE(bad.err.starts_with("bad.hlsl:3: error[K1401]: ")) << bad.err;
  // --werror: a front-end warning (an attribute glslang does not know) fails the compile.
  dir.write("warn.hlsl", "[[vk::unknown_attribute]] float4 main() : SV_Target { return 1.0; }\n");
  auto warned = testing::run_kiln({"compile", "warn.hlsl", "-S", "frag", "-o", "w.spv"}, dir.path());
  EXPECT_EQ(warned.exit_code, 0) << warned.err;
  EXPECT_NE(warned.err.find("warning[K1407]"), std::string::npos) << warned.err;
  auto werror = testing::run_kiln({"compile", "warn.hlsl", "-S", "frag", "-o", "w.spv", "--werror"}, dir.path());
  EXPECT_EQ(werror.exit_code, 1) << werror.err;
}

// kiln compile reads the glslc and DXC spellings users type by habit: each that means what kiln's option means
// gives the bytes kiln's spelling gives (the output, and the depfile where there is one); each that does not is
// refused, exit 1, with kiln's spelling in the error.
TEST_F(Cli, CompileReadsGlslcAndDxcSpellingsAsKilnsOrRefusesThemWithKilnsSpelling) {
  dir.write("x.hlsl", "Texture2D tex : register(t0);\nSamplerState smp : register(s1);\n"
                      "cbuffer Tint : register(b2) { float4 tint; };\n"
                      "float4 F(float2 uv : TEXCOORD0) : SV_Target { return tex.Sample(smp, uv) * tint; }\n"
                      "float4 main(float4 p : POSITION) : SV_Position { return p * tint; }\n");
  dir.write("warn.hlsl", "[[vk::unknown_attribute]] float4 main() : SV_Target { return 1.0; }\n");
  dir.write("define.hlsl", "float4 main() : SV_Target { return VALUE; }\n");  // no build without a VALUE
  struct Same {
    std::vector<std::string> habit, kiln;  // after "compile"; each writes o.spv (and o.d where a depfile is asked for)
  };
  const std::vector<Same> accepted = {
      {{"x.hlsl", "-fshader-stage=frag", "-E", "F", "-o", "o.spv"}, {"x.hlsl", "-S", "frag", "-E", "F", "-o", "o.spv"}},
      {{"x.hlsl", "-S", "frag", "-fentry-point=F", "-o", "o.spv"}, {"x.hlsl", "-S", "frag", "-E", "F", "-o", "o.spv"}},
      {{"x.hlsl", "-S", "frag", "-e", "F", "-o", "o.spv"}, {"x.hlsl", "-S", "frag", "-E", "F", "-o", "o.spv"}},
      {{"x.hlsl", "-T", "ps_6_0", "-E", "F", "-o", "o.spv"}, {"x.hlsl", "-S", "fragment", "-E", "F", "-o", "o.spv"}},
      {{"x.hlsl", "-Tps_6_6", "-E", "F", "-o", "o.spv"}, {"x.hlsl", "-S", "fragment", "-E", "F", "-o", "o.spv"}},
      {{"x.hlsl", "-T", "vs_6_0", "-o", "o.spv"}, {"x.hlsl", "-S", "vertex", "-o", "o.spv"}},
      {{"x.hlsl", "-S", "frag", "-E", "F", "-Fo", "o.spv"}, {"x.hlsl", "-S", "frag", "-E", "F", "-o", "o.spv"}},
      {{"x.hlsl", "-S", "frag", "-E", "F", "-spirv", "-o", "o.spv"}, {"x.hlsl", "-S", "frag", "-E", "F", "--target", "spirv", "-o", "o.spv"}},
      {{"x.hlsl", "-x", "hlsl", "-S", "frag", "-E", "F", "-o", "o.spv"}, {"x.hlsl", "-S", "frag", "-E", "F", "-o", "o.spv"}},
      {{"warn.hlsl", "-S", "frag", "-Werror", "-o", "o.spv"}, {"warn.hlsl", "-S", "frag", "--werror", "-o", "o.spv"}},
      {{"warn.hlsl", "-S", "frag", "-WX", "-o", "o.spv"}, {"warn.hlsl", "-S", "frag", "--werror", "-o", "o.spv"}},
      {{"x.hlsl", "-S", "frag", "-E", "F", "-MD", "-MF", "o.d", "-o", "o.spv"}, {"x.hlsl", "-S", "frag", "-E", "F", "--depfile", "o.d", "-o", "o.spv"}},
      {{"x.hlsl", "-S", "frag", "-E", "F", "-MD", "-o", "o.spv"}, {"x.hlsl", "-S", "frag", "-E", "F", "--depfile", "o.spv.d", "-o", "o.spv"}},
      {{"x.hlsl", "-S", "frag", "-E", "F", "-fvk-t-shift", "16", "0", "-o", "o.spv"},
       {"x.hlsl", "-S", "frag", "-E", "F", "--fvk-t-shift", "16", "0", "-o", "o.spv"}},
      {{"x.hlsl", "-S", "frag", "-E", "F", "-fvk-s-shift", "8", "all", "-fvk-b-shift", "4", "0", "-o", "o.spv"},
       {"x.hlsl", "-S", "frag", "-E", "F", "--fvk-s-shift", "8", "all", "--fvk-b-shift", "4", "0", "-o", "o.spv"}},
      {{"x.hlsl", "-S", "frag", "-E", "F", "-O", "-o", "o.spv"}, {"x.hlsl", "-S", "frag", "-E", "F", "-O", "s", "-o", "o.spv"}},
      {{"x.hlsl", "-S", "frag", "-E", "F", "-O3", "-o", "o.spv"}, {"x.hlsl", "-S", "frag", "-E", "F", "-O", "s", "-o", "o.spv"}},
      {{"x.hlsl", "-S", "frag", "-E", "F", "-Od", "-o", "o.spv"}, {"x.hlsl", "-S", "frag", "-E", "F", "-O", "0", "-o", "o.spv"}},
      {{"x.hlsl", "-S", "pixel", "-E", "F", "-o", "o.spv"}, {"x.hlsl", "-S", "fragment", "-E", "F", "-o", "o.spv"}},
      {{"x.hlsl", "-S", "ps", "-E", "F", "-o", "o.spv"}, {"x.hlsl", "-S", "fragment", "-E", "F", "-o", "o.spv"}},
      {{"x.hlsl", "-S", "vs", "-o", "o.spv"}, {"x.hlsl", "-S", "vertex", "-o", "o.spv"}},
      {{"x.hlsl", "-S", "vert", "-o", "o.spv"}, {"x.hlsl", "-S", "vertex", "-o", "o.spv"}},
      // Environments that load kiln's SPIR-V 1.3 for Vulkan 1.1, and HLSL versions glslang's HLSL reads: what kiln builds.
      {{"x.hlsl", "-S", "frag", "-E", "F", "--target-env=vulkan1.1", "-o", "o.spv"}, {"x.hlsl", "-S", "frag", "-E", "F", "-o", "o.spv"}},
      {{"x.hlsl", "-S", "frag", "-E", "F", "--target-env", "vulkan1.2", "-o", "o.spv"}, {"x.hlsl", "-S", "frag", "-E", "F", "-o", "o.spv"}},
      {{"x.hlsl", "-S", "frag", "-E", "F", "-fspv-target-env=vulkan1.3", "-o", "o.spv"}, {"x.hlsl", "-S", "frag", "-E", "F", "-o", "o.spv"}},
      {{"x.hlsl", "-S", "frag", "-E", "F", "-HV", "2021", "-o", "o.spv"}, {"x.hlsl", "-S", "frag", "-E", "F", "-o", "o.spv"}},
      {{"x.hlsl", "-S", "frag", "-E", "F", "-HV2018", "-o", "o.spv"}, {"x.hlsl", "-S", "frag", "-E", "F", "-o", "o.spv"}},
      {{"x.hlsl", "-S", "frag", "-E", "F", "-enable-16bit-types", "-o", "o.spv"}, {"x.hlsl", "-S", "frag", "-E", "F", "-o", "o.spv"}},
      // glslc's -DNAME and -DNAME=VALUE, without a space.
      {{"define.hlsl", "-S", "frag", "-DVALUE", "-o", "o.spv"}, {"define.hlsl", "-S", "frag", "-D", "VALUE", "-o", "o.spv"}},
      {{"define.hlsl", "-S", "frag", "-DVALUE=0.5", "-o", "o.spv"}, {"define.hlsl", "-S", "frag", "-D", "VALUE=0.5", "-o", "o.spv"}},
  };
  auto run = [&](std::vector<std::string> args) {
    std::filesystem::remove(dir / "o.spv");
    std::filesystem::remove(dir / "o.d");
    std::filesystem::remove(dir / "o.spv.d");
    args.insert(args.begin(), "compile");
    testing::RunResult r = testing::run_kiln(args, dir.path());
    std::string written;
    for (const char* name : {"o.spv", "o.d", "o.spv.d"})
      if (std::filesystem::exists(dir / name)) written += std::string(name) + ":" + testing::read_file(dir / name) + "\n";
    return std::make_tuple(r.exit_code, r.err, written);
  };
  for (const Same& same : accepted) {
    const auto kiln = run(same.kiln);
    const auto habit = run(same.habit);
    const std::string what = same.habit[1] + " " + same.habit[2] + " " + same.habit[3];
    EXPECT_EQ(habit, kiln) << what;
    if (same.habit[0] != "warn.hlsl") EXPECT_EQ(std::get<0>(kiln), 0) << what << ": " << std::get<1>(kiln);
    else EXPECT_EQ(std::get<0>(kiln), 1) << what;  // a warning with -Werror is an error
  }

  struct Refused {
    std::vector<std::string> habit;
    std::string hint;  // the whole error
  };
  const std::vector<Refused> refused = {
      {{"-T", "lib_6_3"}, "-T 'lib_6_3' is a library profile, every entry point of the file at once; kiln compile builds one stage: "
                          "use '-S STAGE -E ENTRY' once for each entry point (or a pack, kiln build)"},
      {{"-T", "ms_6_5"}, "-T 'ms_6_5': glslang 12, kiln's HLSL front end, has no mesh or amplification shaders (DXC -T ms_6_5/as_6_5 builds them)"},
      {{"-T", "ps_5_0"}, "-T 'ps_5_0' is no DXC profile kiln reads (expected vs, ps, cs, gs, hs or ds, then _6_0 to _6_8): use '-S STAGE'"},
      {{"-S", "mesh"}, "-S 'mesh': glslang 12, kiln's HLSL front end, has no mesh or amplification shaders (DXC -T ms_6_5/as_6_5 builds them)"},
      {{"-x", "glsl"}, "-x 'glsl': kiln compiles HLSL only; for HLSL, use '-x hlsl' or nothing"},
      {{"-Zi"}, "DXC's '-Zi' is not kiln's: kiln's -g also turns the optimizer off, as -Zi -Od does: use '-g'"},
      {{"-M"}, "glslc's '-M' is not kiln's: it writes the dependencies instead of compiling; kiln compile writes them beside the "
               "output: use '--depfile FILE'"},
      {{"-MD", "-o", "-"}, "-MD with -o -: no output file to name the depfile after: use '--depfile FILE'"},
      {{"--target-env=vulkan1.0"}, "--target-env 'vulkan1.0': kiln's modules are SPIR-V 1.3 for Vulkan 1.1 (the manifest's "
                                   "spirv_env, vulkan1.1), which only vulkan1.1, vulkan1.2 and vulkan1.3 load, and kiln builds "
                                   "for no other environment: use one of those, or nothing"},
      {{"-fspv-target-env=universal1.5"}, "-fspv-target-env 'universal1.5': kiln's modules are SPIR-V 1.3 for Vulkan 1.1 (the "
                                          "manifest's spirv_env, vulkan1.1), which only vulkan1.1, vulkan1.2 and vulkan1.3 load, "
                                          "and kiln builds for no other environment: use one of those, or nothing"},
      {{"--target-env", "opengl4.5"}, "--target-env 'opengl4.5': kiln's modules are for Vulkan 1.1; for OpenGL, use '--target glsl' "
                                      "(GLSL 4.50 made from the same module)"},
      {{"-HV", "202x"}, "-HV '202x': kiln's HLSL front end, glslang 12, reads HLSL 2018 and, of HLSL 2021, select, and and or "
                        "(not templates, operator overloading or bit fields): use '-HV 2021', '-HV 2018' or nothing"},
      {{"-fvk-use-dx-layout"}, "DXC's '-fvk-use-dx-layout' is not kiln's: kiln lays out constant buffers by glslang's Vulkan rules "
                               "(an array's elements, and the member after an array, start on 16 bytes), not by DirectX's "
                               "packing: state the offsets that must match D3D's with packoffset or [[vk::offset(N)]] "
                               "(docs/bindings.md)"},
  };
  for (const Refused& r : refused) {
    std::vector<std::string> args{"compile", "x.hlsl", "-E", "F"};
    if (r.habit[0] != "-T" && r.habit[0] != "-S") args.insert(args.end(), {"-S", "frag"});
    if (r.habit.back() != "-") args.insert(args.end(), {"-o", "o.spv"});
    args.insert(args.end(), r.habit.begin(), r.habit.end());
    std::filesystem::remove(dir / "o.spv");
    auto result = testing::run_kiln(args, dir.path());
    EXPECT_EQ(result.exit_code, 1) << r.habit[0];
    EXPECT_EQ(result.err, "<command line>: error[K1014]: " + r.hint + "\n") << r.habit[0];
    EXPECT_FALSE(std::filesystem::exists(dir / "o.spv")) << r.habit[0];
  }
}

// kiln compile's messages speak of the file, the stage and its -D keywords, not of the one-pass pack it builds
// ("pass 'main'", "in 1 variant", "the pack definition").
TEST_F(Cli, CompileMessagesSpeakOfTheFileAndTheStage) {
  dir.write("fog.hlsl", "#pragma multi_compile _ FOG\nfloat4 main() : SV_Target {\n#ifdef FOG\n  return undefined_fog;\n#endif\n"
                        "  return 1;\n}\n");
  auto fog = testing::run_kiln({"compile", "fog.hlsl", "-S", "frag", "-o", "o.spv"}, dir.path());
  EXPECT_EQ(fog.exit_code, 1);
  EXPECT_EQ(fog.err, "fog.hlsl:4:10: error[K1401]: 'undefined_fog' : unknown variable\n"
                     "      return undefined_fog;\n"
                     "             ^\n"
                     "  note: in the fragment stage of fog.hlsl with -D FOG\n");
  dir.write("clash.hlsl", "Texture2D tex : register(t0);\nSamplerState smp : register(s1);\n"
                          "cbuffer C : register(b0) { float4 tint; };\n"
                          "float4 main(float2 uv : TEXCOORD0) : SV_Target { return tex.Sample(smp, uv) * tint; }\n");
  auto clash = testing::run_kiln({"compile", "clash.hlsl", "-S", "pixel", "-o", "o.spv"}, dir.path());
  EXPECT_EQ(clash.exit_code, 1);
  EXPECT_TRUE(clash.err.starts_with("clash.hlsl:3:9: error[K1406]: set 0 binding 0 holds both 'C' (uniform_buffer) and 'tex' "
                                    "(texture) in the fragment stage\n"))
      << clash.err;
  EXPECT_NE(clash.err.find("  note: registers of different classes share a number: shift one class, e.g. --fvk-t-shift 16 0 "
                           "(DXC's -fvk-t-shift), or give one of them [[vk::binding(N, 0)]]\n"),
            std::string::npos)
      << clash.err;
  auto missing = testing::run_kiln({"compile", "clash.hlsl", "-S", "frag", "-E", "PSMain", "-o", "o.spv"}, dir.path());
  EXPECT_EQ(missing.err, "<command line>: error[K1402]: entry point 'PSMain' of the fragment stage is not defined in 'clash.hlsl'\n"
                         "  note: in the fragment stage of clash.hlsl\n");
  for (const std::string& err : {fog.err, clash.err, missing.err}) {
    EXPECT_EQ(err.find("pass '"), std::string::npos) << err;
    EXPECT_EQ(err.find(" variant"), std::string::npos) << err;
    EXPECT_EQ(err.find("pack definition"), std::string::npos) << err;
  }
}

// kiln compile -g: the module carries the HLSL source (the entry file and its includes, preprocessed) and line
// numbers, on every variant the file's keywords make; without -g, neither. glslang 12 read a debug scope it never
// pushed at each lexical block and crashed under kiln's allocator (frontend/glslang_shader.hpp): the shader has
// blocks in a loop, a branch and a bare pair of braces.
// The reflection names each input's and output's HLSL semantic (a game binds its vertex streams by them), for struct
// members and entry parameters, in any case as written; the modules carry none of the decorations that brought them
// from the front end to the back end.
TEST_F(Cli, ReflectionNamesTheHlslSemanticsOfInputsAndOutputs) {
  dir.write("S.hlsl", "struct VIn { float3 pos : Position; float2 uv : TEXCOORD0; };\n"
                      "struct VOut { float4 p : SV_Position; float2 uv : TEXCOORD3; };\n"
                      "VOut V(VIn i, float4 tint : COLOR1) { VOut o; o.p = float4(i.pos, 1) * tint; o.uv = i.uv; return o; }\n"
                      "float4 F(VOut i) : SV_Target { return float4(i.uv, 0, 1); }\n");
  ASSERT_EQ(build().exit_code, 0);
  PackReader pack = PackReader::open(dir / "out");
  const SelectedVariant variant = pack.select("P", {});
  auto semantics = [](const std::vector<StageVariable>& variables) {
    std::map<uint32_t, std::string> by_location;
    for (const StageVariable& v : variables) by_location[v.location] = v.name + " " + v.semantic;
    return by_location;
  };
  const StageView* vertex = variant.stage("vertex");
  const StageView* fragment = variant.stage("fragment");
  ASSERT_TRUE(vertex && fragment);
  EXPECT_EQ(semantics(vertex->reflection->inputs),
            (std::map<uint32_t, std::string>{{0, "i.pos POSITION"}, {1, "i.uv TEXCOORD0"}, {2, "tint COLOR1"}}));
  EXPECT_EQ(semantics(vertex->reflection->outputs), (std::map<uint32_t, std::string>{{0, "@entryPointOutput.uv TEXCOORD3"}}));
  EXPECT_EQ(semantics(fragment->reflection->inputs), (std::map<uint32_t, std::string>{{0, "i.uv TEXCOORD3"}}));
  EXPECT_EQ(semantics(fragment->reflection->outputs), (std::map<uint32_t, std::string>{{0, "@entryPointOutput SV_TARGET"}}));
  for (const StageView* view : {vertex, fragment}) {
    EXPECT_EQ(view->spirv.find("SPV_GOOGLE_hlsl_functionality1"), std::string::npos) << view->stage;
    EXPECT_EQ(view->spirv.find("TEXCOORD"), std::string::npos) << view->stage;
  }
  EXPECT_NE(testing::read_file(dir / "out/p.manifest.json").find("COLOR1"), std::string::npos);
}

// Whether a SPIR-V module holds an OpLine (opcode 8), walking its instructions from the header.
bool has_op_line(const std::string& bytes) {
  std::vector<uint32_t> words(bytes.size() / 4);
  std::memcpy(words.data(), bytes.data(), words.size() * 4);
  for (size_t i = 5; i < words.size();) {
    const uint32_t count = words[i] >> 16;
    if ((words[i] & 0xFFFF) == 8) return true;
    if (count == 0) return false;
    i += count;
  }
  return false;
}

TEST_F(Cli, CompileWithGKeepsTheHlslSourceAndLinesForEveryVariant) {
  dir.write("inc/Fog.hlsli", "float4 FogIncludeMarker(float4 c) { { c.rgb *= 0.5; } return c; }\n");
  dir.write("x.hlsl", "#pragma multi_compile _ FOG\n#pragma multi_compile Q0 Q1 Q2 Q3\n#include \"Fog.hlsli\"\n"
                      "cbuffer Tint : register(b0) { float4 tint; int count; };\n"
                      "float4 main(float2 uv : TEXCOORD0) : SV_Target {\n  float4 c = tint;\n"
                      "  for (int i = 0; i < count; ++i) { float k = uv.x * i; c.r += k; }\n"
                      "  if (uv.y > 0.5) { c.g = 1; }\n#ifdef FOG\n  c = FogIncludeMarker(c);\n#endif\n  return c;\n}\n");
  for (const std::string fog : {"", "FOG"}) {
    std::vector<std::string> args{"compile", "x.hlsl", "-S", "frag", "-I", "inc", "-g", "-D", "Q2", "-o", "g.spv"};
    if (!fog.empty()) args.insert(args.end(), {"-D", fog});
    auto debug = testing::run_kiln(args, dir.path());
    ASSERT_EQ(debug.exit_code, 0) << debug.err;
    const std::string spirv = testing::read_file(dir / "g.spv");
    EXPECT_NE(spirv.find("cbuffer Tint : register(b0)"), std::string::npos) << "the entry file's source text, " << fog;
    EXPECT_NE(spirv.find("float4 FogIncludeMarker(float4 c)"), std::string::npos) << "the include's source text, " << fog;
    EXPECT_NE(spirv.find("Fog.hlsli"), std::string::npos) << "the include's name, for its lines, " << fog;
    EXPECT_TRUE(has_op_line(spirv)) << fog;
  }
  auto plain = testing::run_kiln({"compile", "x.hlsl", "-S", "frag", "-I", "inc", "-O0", "-D", "Q2", "-o", "p.spv"}, dir.path());
  ASSERT_EQ(plain.exit_code, 0) << plain.err;
  EXPECT_EQ(testing::read_file(dir / "p.spv").find("cbuffer Tint"), std::string::npos);
  EXPECT_FALSE(has_op_line(testing::read_file(dir / "p.spv")));
  // The debug module cross-compiles as any other.
  auto glsl = testing::run_kiln({"compile", "x.hlsl", "-S", "frag", "-I", "inc", "-g", "-D", "Q0", "-o", "g.frag"}, dir.path());
  ASSERT_EQ(glsl.exit_code, 0) << glsl.err;
  EXPECT_TRUE(testing::read_file(dir / "g.frag").starts_with("#version 450"));
  // -D keywords that select no variant are the command line's fault, not kiln's.
  auto none = testing::run_kiln({"compile", "x.hlsl", "-S", "frag", "-I", "inc", "-D", "FOG", "-o", "n.spv"}, dir.path());
  EXPECT_EQ(none.exit_code, 1) << none.err;
  EXPECT_TRUE(none.err.starts_with("<command line>: error[K1014]: -D: the keywords select no variant: pass 'main' needs one of: "
                                   "Q0 Q1 Q2 Q3"))
      << none.err;
}

// DXC and glslangValidator keep the files as written in a -g module's OpSource: comments, spacing and all, each
// include its own OpSource. kiln preprocesses first, so two files that differ in a comment preprocess alike: with
// -g they are two cache entries, or the second build would carry the first one's comment.
TEST_F(Cli, CompileWithGKeepsTheFilesAsWrittenAndACommentEditIsANewModule) {
  const std::string header = "// Fog.hlsli: the author's note on fog\nfloat4  Fogged( float4 c )  { return c * 0.5; }\n";
  auto entry = [](const std::string& comment) {
    return "#include \"Fog.hlsli\"\n/* " + comment + " */\nfloat4 main(float2 uv : TEXCOORD0) : SV_Target\n{\n"
           "    return   Fogged(float4(uv, 0, 1));   // spaced as the author likes\n}\n";
  };
  dir.write("inc/Fog.hlsli", header);
  for (const std::string comment : {"the first comment", "the second comment"}) {
    dir.write("x.hlsl", entry(comment));
    auto r = testing::run_kiln({"compile", "x.hlsl", "-S", "frag", "-I", "inc", "-g", "-o", "g.spv"}, dir.path());
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const std::string spirv = testing::read_file(dir / "g.spv");
    EXPECT_NE(spirv.find(entry(comment)), std::string::npos) << "the entry file as written, with '" << comment << "'";
    EXPECT_NE(spirv.find(header), std::string::npos) << "the include as written";
    EXPECT_TRUE(has_op_line(spirv));
  }
  // kiln build -g with its cache: the comment edit compiles anew (the preprocessed text is the same), so the pack
  // holds the new comment; the edit back is the first build's entry again.
  dir.write("lib/Fog.hlsli", header);
  for (const std::string comment : {"one", "two", "one"}) {
    dir.write("S.hlsl", std::regex_replace(entry(comment), std::regex("float4 main"),
                                           "struct VO { float4 p : SV_Position; float2 uv : TEXCOORD0; };\n"
                                           "VO V(float4 p : POSITION) { VO o; o.p = p; o.uv = p.xy; return o; }\nfloat4 F"));
    auto r = build({"-g"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const StageView* fragment = PackReader::open(dir / "out").select("P", {}).stage("fragment");
    ASSERT_TRUE(fragment);
    EXPECT_NE(fragment->spirv.find("/* " + comment + " */"), std::string::npos) << "the comment of this build, '" << comment << "'";
  }
}

}  // namespace
}  // namespace kiln
