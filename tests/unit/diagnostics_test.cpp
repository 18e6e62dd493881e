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

TEST(Diagnostics, FormatPrintsPathLineColumnSourceLineAndCaret) {
  testing::TempDir dir;
  auto file = dir.write("a.hlsl", "float x;\n  float4 y = oops;\n");
  Diagnostic d{DiagId::HlslError, Severity::Error, SourceLocation{file.string(), 2, 14}, "'oops' : undeclared identifier", {"in pass 'P'"}};
  EXPECT_EQ(format_diagnostic(d), file.string() + ":2:14: error[K1401]: 'oops' : undeclared identifier\n"
                                   "      float4 y = oops;\n"
                                   "                 ^\n"
                                   "  note: in pass 'P'\n");
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
