// SPDX-License-Identifier: Apache-2.0
#include <gtest/gtest.h>

#include <set>

#include "kiln/diagnostics.hpp"
#include "test_support.hpp"

namespace kiln {
namespace {

TEST(Diagnostics, IdsInTheTableAreUniqueAndStable) {
  std::set<unsigned> seen;
  for (const DiagInfo& info : diagnostic_table()) EXPECT_TRUE(seen.insert(static_cast<unsigned>(info.id)).second);
  EXPECT_EQ(diagnostic_code(DiagId::IncludeCycle), "K1203");
  EXPECT_EQ(diagnostic_code(DiagId::InternalCompilerError), "K1501");
}

// The diagnostics a sink received, as the CLI prints them.
std::string printed(const DiagnosticSink& sink) {
  std::string out;
  for (const Diagnostic& d : sink.diagnostics()) out += format_diagnostic(d);
  return out;
}

TEST(Diagnostics, FormatPrintsPathLineColumnSourceLineAndCaret) {
  DiagnosticSink sink;
  sink.add_source("a.hlsl", std::make_shared<const std::string>("float x;\n  float4 y = oops;\n"));
  sink.report(DiagId::HlslError, SourceLocation{"a.hlsl", 2, 14}, "'oops' : undeclared identifier", {"in pass 'P'"});
  EXPECT_EQ(printed(sink), "a.hlsl:2:14: error[K1401]: 'oops' : undeclared identifier\n"
                           "      float4 y = oops;\n"
                           "                 ^\n"
                           "  note: in pass 'P'\n");
}

TEST(Diagnostics, OnlyFilesGivenToTheSinkAreQuotedNeverFilesOnDisk) {
  testing::TempDir dir;
  auto file = dir.write("secret.txt", "line one\nSECRET_MARKER\n");
  DiagnosticSink sink;
  sink.report(DiagId::HlslError, SourceLocation{file.string(), 2, 1}, "'x' : unknown variable");
  EXPECT_EQ(printed(sink), file.string() + ":2:1: error[K1401]: 'x' : unknown variable\n");
  // Lines past the end quote nothing.
  sink.add_source("a.hlsl", std::make_shared<const std::string>("one line\n"));
  sink.report(DiagId::HlslError, SourceLocation{"a.hlsl", 2, 1}, "past the end");
  EXPECT_EQ(sink.diagnostics().back().source_line, std::nullopt);
}

TEST(Diagnostics, AQuotedLineIsCutToABoundWithoutSplittingACharacter) {
  DiagnosticSink sink;
  std::string huge = std::string(kMaxQuotedLineBytes - 1, 'a') + "\xC3\xA9" + std::string(1 << 20, 'b');
  sink.add_source("min.hlsl", std::make_shared<const std::string>(huge));
  sink.report(DiagId::HlslError, SourceLocation{"min.hlsl", 1, 0}, "e");
  EXPECT_EQ(sink.diagnostics().back().source_line, std::string(kMaxQuotedLineBytes - 1, 'a') + " ...");
}

TEST(Diagnostics, SinkCollectsEveryMessageAndCountsErrors) {
  DiagnosticSink sink;
  sink.report(DiagId::HlslWarning, {}, "w");
  sink.report(DiagId::HlslError, {}, "e1");
  sink.report(DiagId::IncludeCycle, {}, "e2");
  EXPECT_EQ(sink.error_count(), 2);
  EXPECT_EQ(sink.warning_count(), 1);
  EXPECT_TRUE(sink.contains(DiagId::IncludeCycle));
}

TEST(Diagnostics, ClosestMatchSuggestsOnlyPlausibleTypos) {
  std::vector<std::string> known{"_MAIN_LIGHT_SHADOWS", "_SHADOWS_SOFT", "_FORWARD_PLUS"};
  EXPECT_EQ(closest_match("_MAIN_LIGHT_SHADOW", known), "_MAIN_LIGHT_SHADOWS");
  EXPECT_EQ(closest_match("_SHADOW_SOFT", known), "_SHADOWS_SOFT");
  EXPECT_FALSE(closest_match("COMPLETELY_DIFFERENT", known).has_value());
  // Two swapped letters are one typo.
  EXPECT_EQ(closest_match("_FROWARD_PLUS", known), "_FORWARD_PLUS");
  std::vector<std::string> verbs{"build", "list", "inspect", "lint"};
  EXPECT_EQ(closest_match("biuld", verbs), "build");
  EXPECT_EQ(closest_match("lsit", verbs), "list");
  EXPECT_FALSE(closest_match("xyzzy", verbs).has_value());
}

}  // namespace
}  // namespace kiln
