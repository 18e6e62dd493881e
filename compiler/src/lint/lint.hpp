// kiln lint: rules over a pack's sources, its variant plan and its compiled outputs, for CI.
// Each rule has a stable id; findings print as `path:line:col: warning[rule-id]: message`, or as JSON,
// or as SARIF 2.1.0 for code-scanning viewers.
#pragma once

#include <string>
#include <vector>

#include "kiln/build.hpp"

namespace kiln {

struct LintRule {
  std::string id;
  Severity severity;
  std::string description;
};

// The rule table, in a stable order.
const std::vector<LintRule>& lint_rules();

struct LintFinding {
  std::string rule;
  Severity severity = Severity::Warning;
  SourceLocation location;
  std::string message;
  std::vector<std::string> notes;
};

struct LintReport {
  std::vector<LintFinding> findings;
  int errors() const;
  int warnings() const;
};

// Lints a pack definition: builds it into options.output_dir (a scratch directory) and runs every rule.
LintReport lint_pack(const BuildOptions& options);
// Lints loose HLSL files: only the source rules (undeclared keywords, fp16 guards).
LintReport lint_files(const std::vector<std::filesystem::path>& files);

// Source rules, exposed for tests: `declared` are the keywords of every pass; `sources` display path -> text.
void lint_undeclared_keywords(const std::vector<std::pair<std::string, std::string>>& sources,
                              const std::vector<std::string>& declared, LintReport& report);
void lint_fp16_guards(const std::vector<std::pair<std::string, std::string>>& sources, LintReport& report);

std::string format_lint_text(const LintReport& report);
std::string format_lint_json(const LintReport& report);
std::string format_lint_sarif(const LintReport& report);

}  // namespace kiln
