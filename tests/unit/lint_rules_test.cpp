// SPDX-License-Identifier: Apache-2.0
// Each lint rule on its own, through the registry, on inputs made here (no build): every rule has a case that
// triggers it and one that does not.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <algorithm>

#include "layouts/interface_check.hpp"
#include "lint/lint.hpp"

namespace kiln {
namespace {

std::vector<RuleId> rules_of(const LintReport& report) {
  std::vector<RuleId> ids;
  for (const LintFinding& f : report.findings) ids.push_back(f.rule);
  return ids;
}

LintReport run(const LintRule& rule, const LintContext& context) {
  LintReport report;
  rule.check(context, report);
  return report;
}

KeywordGroup group(std::string pragma, std::vector<std::string> values, int line) {
  KeywordGroup g;
  g.pragma = pragma;
  g.values = std::move(values);
  g.material_feature = pragma.starts_with("shader_feature");
  g.declared_at = SourceLocation{"S.hlsl", line, 1};
  return g;
}

TEST(LintRules, TheRegistryListsEveryRuleOnceInRuleIdOrderWithItsDocumentation) {
  ASSERT_EQ(lint_rules().size(), kRuleCount);
  for (size_t i = 0; i < kRuleCount; ++i) {
    const LintRule& rule = *lint_rules()[i];
    EXPECT_EQ(static_cast<size_t>(rule.id), i);
    EXPECT_FALSE(rule.name.empty());
    EXPECT_TRUE(rule.short_description.ends_with(".")) << rule.id_text();
    EXPECT_GT(rule.full_description.size(), rule.short_description.size()) << rule.id_text();
    EXPECT_EQ(rule.help_anchor(), rule.id_text());
    // A rule checks something, or names the build diagnostic it reports (build-error takes the rest).
    EXPECT_EQ(rule.check == nullptr, rule.input == LintInput::BuildDiagnostic) << rule.id_text();
  }
}

TEST(LintRules, UnusedKeywordIsAKeywordWhoseVariantsAreIdenticalToTheOnesWithout) {
  PlanListing plan;
  plan.pass_groups.push_back({"P", {group("multi_compile_fragment", {"", "UNUSED"}, 1), group("multi_compile", {"", "USED"}, 2)}});
  PackView pack;
  pack.passes.push_back({"P",
                         {{{}, {{"fragment", 0}}},
                          {{"UNUSED"}, {{"fragment", 0}}},
                          {{"USED"}, {{"fragment", 1}}},
                          {{"UNUSED", "USED"}, {{"fragment", 1}}}}});
  LintContext context;
  context.plan = &plan;
  context.pack = &pack;
  LintReport report = run(lint_rule(RuleId::UnusedKeyword), context);
  ASSERT_EQ(rules_of(report), std::vector<RuleId>{RuleId::UnusedKeyword});
  EXPECT_EQ(report.findings[0].location.line, 1);
  EXPECT_EQ(report.findings[0].message,
            "keyword 'UNUSED' changes no compiled code of pass 'P': every variant with it is identical to the one without");
  pack.passes[0].variants[3].binaries["fragment"] = 2;  // UNUSED now changes [USED]'s code
  EXPECT_TRUE(run(lint_rule(RuleId::UnusedKeyword), context).findings.empty());
}

TEST(LintRules, UndeclaredKeywordIsATestedNameNothingDeclaresOrDefines) {
  LintContext context;
  context.declared = {"_MAIN_LIGHT_SHADOWS"};
  context.sources = {{"S.hlsl", "#define LIBRARY_MACRO 1\n#if defined(_MAIN_LIGHT_SHADOW) && LIBRARY_MACRO\n#endif\n#ifdef _MAIN_LIGHT_SHADOWS\n#endif\n"}};
  LintReport report = run(lint_rule(RuleId::UndeclaredKeyword), context);
  ASSERT_EQ(rules_of(report), std::vector<RuleId>{RuleId::UndeclaredKeyword});
  EXPECT_EQ(report.findings[0].location.line, 2);
  EXPECT_EQ(report.findings[0].location.column, 13);
  EXPECT_EQ(report.findings[0].notes, std::vector<std::string>{"did you mean '_MAIN_LIGHT_SHADOWS'?"});
  context.declared.push_back("_MAIN_LIGHT_SHADOW");
  EXPECT_TRUE(run(lint_rule(RuleId::UndeclaredKeyword), context).findings.empty());
}

TEST(LintRules, MultiCompileCouldBeFeatureWhenNoSceneEnablesAnyOfItsKeywords) {
  PlanListing plan;
  plan.pass_groups.push_back({"P", {group("multi_compile", {"", "RARE"}, 1), group("multi_compile", {"", "COMMON"}, 2),
                                    group("shader_feature", {"", "MATERIAL"}, 3)}});
  plan.scenes.push_back({"day", {"COMMON"}});
  LintContext context;
  context.plan = &plan;
  LintReport report = run(lint_rule(RuleId::MultiCompileCouldBeFeature), context);
  ASSERT_EQ(rules_of(report), std::vector<RuleId>{RuleId::MultiCompileCouldBeFeature});
  EXPECT_EQ(report.findings[0].location.line, 1);
  plan.scenes.push_back({"night", {"RARE"}});
  EXPECT_TRUE(run(lint_rule(RuleId::MultiCompileCouldBeFeature), context).findings.empty());
  plan.scenes.clear();  // no scene given: nothing to judge by
  EXPECT_TRUE(run(lint_rule(RuleId::MultiCompileCouldBeFeature), context).findings.empty());
}

// The build's check (layouts/interface_check.cpp), which interface-mismatch reports: each distinct pair of the
// fragment binary and the one before it, once, with the variants that use it.
TEST(LintRules, InterfaceMismatchIsAFragmentInputTheStageBeforeDoesNotWriteAlike) {
  Reflection vertex, both, other_type, matching, geometry;
  vertex.outputs = {{"uv", 0, "float2"}};
  both.inputs = {{"uv", 0, "float2"}, {"n", 1, "float3"}};
  other_type.inputs = {{"uv", 0, "float3"}};
  matching.inputs = {{"tex", 0, "float2"}};  // names do not matter
  geometry.outputs = {{"uv", 0, "float2"}, {"n", 1, "float3"}};
  PassLayoutInput input;
  input.pass = "Forward";
  input.pass_location = SourceLocation{"p.pack.json", 3, 15};
  input.variant_names = {"<none>", "B", "C", "B C"};
  input.binaries = {{Stage::Vertex, &vertex, {0, 1, 2, 3}}, {Stage::Fragment, &both, {0}},
                    {Stage::Fragment, &other_type, {1, 3}}, {Stage::Fragment, &matching, {2}}};
  DiagnosticSink sink;
  EXPECT_FALSE(check_stage_interfaces(input, sink));
  ASSERT_EQ(sink.diagnostics().size(), 2u);
  EXPECT_EQ(sink.diagnostics()[0].id, DiagId::InterfaceMismatch);
  EXPECT_EQ(sink.diagnostics()[0].message,
            "pass 'Forward', variant [<none>]: fragment input 'n' (location 1) is not written by the vertex stage");
  EXPECT_EQ(sink.diagnostics()[1].message,
            "pass 'Forward', 2 variants, the first [B]: location 0 is float2 ('uv') in the vertex stage and float3 ('uv') "
            "in the fragment stage");
  EXPECT_EQ(sink.diagnostics()[0].location.line, 3);  // no declaration found: the pass's definition
  EXPECT_EQ(sink.diagnostics()[0].location.column, 15);
  // With the sources, at the fragment input's declaration, and the type mismatch with a note at the output's.
  input.locate_stage_variable = [](const std::string& name, Stage stage) {
    if (name == "n" && stage == Stage::Fragment) return SourceLocation{"S.hlsl", 7, 40};
    if (name == "uv") return SourceLocation{"S.hlsl", stage == Stage::Fragment ? 7 : 2, stage == Stage::Fragment ? 20 : 30};
    return SourceLocation{};
  };
  DiagnosticSink located;
  EXPECT_FALSE(check_stage_interfaces(input, located));
  ASSERT_EQ(located.diagnostics().size(), 3u);
  EXPECT_EQ(located.diagnostics()[0].location.line, 7);
  EXPECT_EQ(located.diagnostics()[0].location.column, 40);
  EXPECT_EQ(located.diagnostics()[1].location.column, 20);
  EXPECT_EQ(located.diagnostics()[2].severity, Severity::Note);
  EXPECT_EQ(located.diagnostics()[2].location.line, 2);
  EXPECT_EQ(located.diagnostics()[2].message, "'uv' is the vertex stage's output declared here");
  EXPECT_EQ(rule_for_diagnostic(DiagId::InterfaceMismatch), RuleId::InterfaceMismatch);
  // A geometry stage is what the fragment stage reads from.
  input.binaries = {{Stage::Vertex, &vertex, {0}}, {Stage::Geometry, &geometry, {0}}, {Stage::Fragment, &both, {0}}};
  input.variant_names = {"<none>"};
  DiagnosticSink quiet;
  EXPECT_TRUE(check_stage_interfaces(input, quiet));
  EXPECT_TRUE(quiet.diagnostics().empty());
}

TEST(LintRules, Fp16UnguardedIsARiskyOperationIn16BitCodeWithNoVisibleGuard) {
  LintContext context;
  context.sources = {{"half.hlsl", "half Ratio(half a, half b)\n{\n    return a / b;\n}\n"
                                   "half Guarded(half a, half b)\n{\n    return a / max(b, (half)1e-3);\n}\n"
                                   "float NotFp16(float a, float b) { return a / b; }\n"}};
  LintReport report = run(lint_rule(RuleId::Fp16Unguarded), context);
  ASSERT_EQ(rules_of(report), std::vector<RuleId>{RuleId::Fp16Unguarded});
  EXPECT_EQ(report.findings[0].location.line, 3);
  context.sources[0].second = "half Ratio(half a, half b)\n{\n    // b >= 0.25: floor applied by the caller\n    return a / b;\n}\n";
  EXPECT_TRUE(run(lint_rule(RuleId::Fp16Unguarded), context).findings.empty());
}

// The rules whose findings are the build's own diagnostics: each claims its K-number; the rest is build-error.
TEST(LintRules, BuildDiagnosticsAreReportedUnderTheRuleThatClaimsThem) {
  EXPECT_EQ(rule_for_diagnostic(DiagId::BudgetExceeded), RuleId::BudgetExceeded);
  EXPECT_EQ(rule_for_diagnostic(DiagId::MissingEntryPoint), RuleId::MissingEntryPoint);
  EXPECT_EQ(rule_for_diagnostic(DiagId::LayoutMismatch), RuleId::LayoutMismatch);
  EXPECT_EQ(rule_for_diagnostic(DiagId::BlockMemberMismatch), RuleId::BlockMemberMismatch);
  EXPECT_EQ(lint_rule(RuleId::BlockMemberMismatch).severity, Severity::Warning);
  EXPECT_EQ(rule_for_diagnostic(DiagId::SpirvInvalid), RuleId::SpirvInvalid);
  EXPECT_EQ(rule_for_diagnostic(DiagId::HlslWarning), RuleId::HlslWarning);
  EXPECT_EQ(rule_for_diagnostic(DiagId::HlslError), RuleId::BuildError);
  EXPECT_EQ(rule_for_diagnostic(DiagId::InternalCompilerError), RuleId::BuildError);
  EXPECT_EQ(lint_rule(RuleId::BudgetExceeded).severity, Severity::Error);
  EXPECT_EQ(lint_rule(RuleId::HlslWarning).severity, Severity::Warning);
}

TEST(LintRules, RulesRunByNeedOnlyWhenTheirInputExists) {
  LintContext context;  // file mode: sources only
  context.sources = {{"S.hlsl", "#ifdef _TYPO_KEYWORD\n#endif\n"}};
  LintReport report;
  run_lint_rules(context, report);
  EXPECT_EQ(rules_of(report), std::vector<RuleId>{RuleId::UndeclaredKeyword});
}

TEST(LintSarif, UrisAreRootRelativeAndPercentEncodedAndEveryResultHasARegion) {
  LintReport report;
  report.findings.push_back({RuleId::BuildError, Severity::Error, SourceLocation{"/work/a b/S.hlsl", 0, 0}, "m", {}});
  report.findings.push_back({RuleId::Fp16Unguarded, Severity::Warning, SourceLocation{"/elsewhere/x#1.hlsl", 4, 2}, "m", {}});
  nlohmann::json log = nlohmann::json::parse(format_lint_sarif(report, {"/work"}));
  const auto& run = log["runs"][0];
  EXPECT_EQ(run["originalUriBaseIds"]["%SRCROOT%"]["uri"], "file:///work/");
  const auto& first = run["results"][0]["locations"][0]["physicalLocation"];
  EXPECT_EQ(first["artifactLocation"]["uri"], "a%20b/S.hlsl");
  EXPECT_EQ(first["artifactLocation"]["uriBaseId"], "%SRCROOT%");
  EXPECT_EQ(first["region"], (nlohmann::json{{"startLine", 1}}));
  const auto& second = run["results"][1]["locations"][0]["physicalLocation"];
  EXPECT_EQ(second["artifactLocation"]["uri"], "file:///elsewhere/x%231.hlsl");
  EXPECT_FALSE(second["artifactLocation"].contains("uriBaseId"));
  EXPECT_EQ(second["region"], (nlohmann::json{{"startLine", 4}, {"startColumn", 2}}));
  EXPECT_EQ(run["results"][1]["ruleIndex"], static_cast<int>(RuleId::Fp16Unguarded));
}

}  // namespace
}  // namespace kiln
