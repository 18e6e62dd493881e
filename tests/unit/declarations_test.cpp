// SPDX-License-Identifier: Apache-2.0
#include <gtest/gtest.h>

#include "common/keyword_pragmas.hpp"
#include "declarations/declarations.hpp"
#include "test_support.hpp"

namespace kiln {
namespace {

// The group, or nothing; a malformed pragma's error goes to `sink` and sets `malformed`, as the scan reports it.
std::optional<KeywordGroup> parse(const std::string& body, DiagnosticSink& sink, bool& malformed) {
  auto parsed = parse_keyword_pragma(body, SourceLocation{"f.hlsl", 3, 1}, 8);
  if (parsed) return *parsed;
  malformed = true;
  sink.report(parsed.error());
  return std::nullopt;
}

// kiln/keyword_kinds.def is the one list of kinds: every folded kind is a pragma with Unity's suffixes, the
// compiler's classifier and the reader's agree on every spelling, names round-trip, and messages list them all.
TEST(Declarations, EveryKeywordKindOfTheTableIsAPragmaTheReaderClassifiesAlike) {
  size_t folded = 0;
  for (const KeywordKindRow& row : kKeywordKinds) {
    SCOPED_TRACE(std::string(row.name));
    EXPECT_EQ(parse_keyword_kind(row.name), row.kind);
    EXPECT_EQ(keyword_kind_name(row.kind), row.name);
    if (!row.folded) {
      EXPECT_FALSE(classify_keyword_pragma(row.name)) << "variant is no pragma of its own";
      continue;
    }
    ++folded;
    for (const char* local : {"", "_local"})
      for (const char* stage : {"", "_vertex", "_fragment", "_geometry", "_hull", "_domain"}) {
        const std::string pragma = std::string(row.name) + local + stage;
        const std::optional<KeywordPragma> kind = classify_keyword_pragma(pragma);
        ASSERT_TRUE(kind) << pragma;
        EXPECT_TRUE(kind->known_suffix) << pragma;
        EXPECT_EQ(kind->kind->keyword_kind, row.kind) << pragma;
        EXPECT_EQ(keyword_kind(pragma), row.kind) << pragma;
        EXPECT_EQ(kind->local, std::string(local) == "_local") << pragma;
      }
  }
  EXPECT_EQ(folded, 3u);
  EXPECT_EQ(keyword_kind_list(), "variant, dynamic_branch, specialization_constant or specialization_constant_int");
  EXPECT_EQ(keyword_kind_list("'", true), "'dynamic_branch', 'specialization_constant' or 'specialization_constant_int'");
  for (const char* variant : {"multi_compile", "shader_feature_local", "multi_compile_fog", "multi_compile_instancing"}) {
    ASSERT_TRUE(classify_keyword_pragma(variant)) << variant;
    EXPECT_EQ(classify_keyword_pragma(variant)->kind->keyword_kind, KeywordKind::Variant) << variant;
    EXPECT_EQ(keyword_kind(variant), KeywordKind::Variant) << variant;
  }
  EXPECT_FALSE(classify_keyword_pragma("specialization_constant_int_local_pixel")->known_suffix);
}

TEST(Declarations, MultiCompileUnderscoreMeansNone) {
  DiagnosticSink sink;
  bool malformed = false;
  auto group = parse(" multi_compile _ _A _B", sink, malformed);
  ASSERT_TRUE(group);
  EXPECT_EQ(group->values, (std::vector<std::string>{"", "_A", "_B"}));
  EXPECT_EQ(group->stages, kAllStageBits);
  EXPECT_FALSE(group->material_feature);
}

TEST(Declarations, StageSuffixesNarrowTheGroupToOneStage) {
  DiagnosticSink sink;
  bool malformed = false;
  EXPECT_EQ(parse(" multi_compile_fragment _ A", sink, malformed)->stages, stage_bit(Stage::Fragment));
  EXPECT_EQ(parse(" multi_compile_vertex _ A", sink, malformed)->stages, stage_bit(Stage::Vertex));
  auto local = parse(" shader_feature_local_fragment _ A", sink, malformed);
  EXPECT_TRUE(local->local);
  EXPECT_TRUE(local->material_feature);
  EXPECT_EQ(local->stages, stage_bit(Stage::Fragment));
}

TEST(Declarations, LoneShaderFeatureKeywordMayBeOffButLoneMultiCompileIsAlwaysOn) {
  DiagnosticSink sink;
  bool malformed = false;
  EXPECT_EQ(parse(" shader_feature A", sink, malformed)->values, (std::vector<std::string>{"", "A"}));
  EXPECT_EQ(parse(" multi_compile A", sink, malformed)->values, (std::vector<std::string>{"A"}));
}

TEST(Declarations, MultiCompileFogExpandsToUnitysFogModes) {
  DiagnosticSink sink;
  bool malformed = false;
  EXPECT_EQ(parse(" multi_compile_fog", sink, malformed)->values,
            (std::vector<std::string>{"", "FOG_LINEAR", "FOG_EXP", "FOG_EXP2"}));
}

TEST(Declarations, FoldedKindsTakeUnitysSuffixesAndALoneKeywordMayBeOff) {
  DiagnosticSink sink;
  bool malformed = false;
  auto branch = parse(" dynamic_branch_local_fragment _ A B", sink, malformed);
  ASSERT_TRUE(branch);
  EXPECT_EQ(branch->kind(), KeywordKind::DynamicBranch);
  EXPECT_TRUE(branch->local);
  EXPECT_EQ(branch->stages, stage_bit(Stage::Fragment));
  EXPECT_EQ(branch->values, (std::vector<std::string>{"", "A", "B"}));
  auto constant = parse(" specialization_constant_vertex A", sink, malformed);
  ASSERT_TRUE(constant);
  EXPECT_EQ(constant->kind(), KeywordKind::SpecializationConstant);
  EXPECT_EQ(constant->stages, stage_bit(Stage::Vertex));
  EXPECT_EQ(constant->values, (std::vector<std::string>{"", "A"}));  // a bool that is always on is no choice
  EXPECT_EQ(parse(" multi_compile _ A", sink, malformed)->kind(), KeywordKind::Variant);
  EXPECT_FALSE(parse(" dynamic_branch_pixel _ A", sink, malformed));
  EXPECT_TRUE(malformed);
}

TEST(Declarations, OtherPragmasAreNotKeywordDeclarations) {
  DiagnosticSink sink;
  bool malformed = false;
  EXPECT_FALSE(parse(" vertex LitVertex", sink, malformed));
  EXPECT_FALSE(malformed);
  EXPECT_FALSE(sink.has_errors());
}

TEST(Declarations, InvalidKeywordNamesAndUnsupportedSuffixesAreErrors) {
  DiagnosticSink sink;
  bool malformed = false;
  EXPECT_FALSE(parse(" multi_compile _ 9BAD", sink, malformed));
  EXPECT_TRUE(malformed);
  EXPECT_TRUE(sink.contains(DiagId::InvalidKeywordName));
  malformed = false;
  // Unity's shortcut for its built-in forward keywords: not kiln's (they name Unity's lights), an error, not a guess.
  EXPECT_FALSE(parse(" multi_compile_fwdbase", sink, malformed));
  EXPECT_TRUE(sink.contains(DiagId::PragmaSyntax));
}

TEST(Declarations, MultiCompileInstancingIsTheInstancingOnGroup) {
  auto group = parse_keyword_pragma(" multi_compile_instancing", SourceLocation{"S.hlsl", 1, 1}, 8);
  ASSERT_TRUE(group && *group);
  EXPECT_EQ((*group)->values, (std::vector<std::string>{"", "INSTANCING_ON"}));
  EXPECT_FALSE(parse_keyword_pragma(" multi_compile_instancing A", SourceLocation{"S.hlsl", 1, 1}, 8));  // takes no keywords
}

TEST(Declarations, ScanCollectsPragmasFromIncludedFilesButNotFromComments) {
  testing::TempDir dir;
  dir.write("lib/Inc.hlsl", "#pragma once\n#pragma multi_compile_fragment _ FROM_INCLUDE\n// #pragma multi_compile _ COMMENTED\n");
  auto entry = dir.write("Main.hlsl",
                         "#pragma multi_compile _ A B\n/* #pragma multi_compile _ BLOCK\n*/\n#include \"Inc.hlsl\"\n");
  IncludeRoots roots({dir.path(), dir / "lib"});
  SourceSet sources;
  DiagnosticSink sink;
  auto result = scan_declarations(entry, roots, ReadLimits{}, sources, sink);
  ASSERT_TRUE(result) << (sink.diagnostics().empty() ? "" : format_diagnostic(sink.diagnostics()[0]));
  ASSERT_EQ(result->groups.size(), 2u);
  EXPECT_EQ(result->groups[0].values, (std::vector<std::string>{"", "A", "B"}));
  EXPECT_EQ(result->groups[1].values, (std::vector<std::string>{"", "FROM_INCLUDE"}));
  EXPECT_EQ(result->files.size(), 2u);
}

TEST(Declarations, KeywordDeclaredInTwoGroupsNamesTheFirstDeclaration) {
  testing::TempDir dir;
  auto entry = dir.write("Main.hlsl", "#pragma multi_compile _ A B\n#pragma shader_feature _ B\n");
  IncludeRoots roots({dir.path()});
  SourceSet sources;
  DiagnosticSink sink;
  EXPECT_FALSE(scan_declarations(entry, roots, ReadLimits{}, sources, sink));
  ASSERT_TRUE(sink.contains(DiagId::KeywordInTwoGroups));
  const Diagnostic d = sink.diagnostics()[0];
  EXPECT_EQ(d.location.line, 2);
  ASSERT_EQ(d.notes.size(), 1u);
  EXPECT_NE(d.notes[0].find("Main.hlsl:1"), std::string::npos);
}

}  // namespace
}  // namespace kiln
