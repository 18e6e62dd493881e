// SPDX-License-Identifier: Apache-2.0
// One lint rule: its id, what it finds, where its documentation is, its default severity and how it checks.
// Each rule lives in rules/<variable>.cpp (one that reports a build diagnostic, in rules/build_findings.cpp) and has
// one row in kiln/lint_rules.def. Adding a rule: its row there, its definition, its section in docs/lint.md, and its
// unit test.
#pragma once

#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "kiln/build.hpp"
#include "lint/pack_view.hpp"
#include "kiln/lint.hpp"
#include "kiln/lint_rule_id.hpp"

namespace kiln {

// What the rules observe. File mode (`kiln lint FILE...`) has sources only; pack mode adds the build's plan
// (stages 0-3) and, when the build succeeded, the built pack.
struct LintContext {
  std::vector<std::pair<std::string, std::string>> sources;  // display path -> text, every file read
  std::vector<std::string> declared;                          // every declared keyword, sorted, unique
  // Pack mode: keywords that shaders under the pack's include roots declare but no file of this build does (the
  // library a shared header belongs to), sorted, unique.
  std::vector<std::string> library_declared;
  std::vector<std::string> defined;  // names the build defines: the pack's and passes' "defines" and -D
  const PlanListing* plan = nullptr;
  const PackView* pack = nullptr;
  std::string pack_file;  // display path of the pack definition (pack mode)

  // Where pass `name` is defined in the pack definition (its "name" value); the pack file when unknown.
  SourceLocation pass_location(const std::string& name) const;
};

// What a rule needs to run: rules run by need (sources, then plan, then pack), in table order within each.
enum class LintInput : unsigned char {
  Sources,          // the source text (both modes)
  Plan,             // keyword groups, scenes (pack mode)
  BuiltPack,        // the built pack's variants and reflection (pack mode, build succeeded)
  BuildDiagnostic,  // no check of its own: the build's diagnostics of `diagnostic` become its findings
};

struct LintRule {
  RuleId id;
  std::string_view name;               // SARIF reportingDescriptor.name: "UnusedKeyword"
  std::string_view short_description;  // one line
  std::string_view full_description;   // a paragraph: what it finds and how
  Severity severity;                   // default severity of its findings
  LintInput input;
  void (*check)(const LintContext&, LintReport&) = nullptr;  // null for BuildDiagnostic rules
  std::optional<DiagId> diagnostic = std::nullopt;            // BuildDiagnostic rules: the pipeline's id

  std::string_view id_text() const { return rule_id_text(id); }
  // The anchor of the rule's section in docs/lint.md: the id itself (GitHub's heading anchors).
  std::string_view help_anchor() const { return rule_id_text(id); }
};

// Every rule, indexed by RuleId.
std::span<const LintRule* const> lint_rules();
const LintRule& lint_rule(RuleId id);

// Adds a finding of `rule` with its default severity.
void add_finding(LintReport& report, RuleId rule, SourceLocation at, std::string message, std::vector<std::string> notes = {});

// Shared by rules: source lines as written (comments kept), for comments that state a bound.
std::vector<std::string> raw_lines(const std::string& text);

}  // namespace kiln
