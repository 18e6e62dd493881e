// SPDX-License-Identifier: Apache-2.0
// kiln lint as a library (the compiler's public API, kiln::compiler): rules over a pack's sources, its variant plan
// and its compiled outputs, for CI and editors. Findings print as `path:line:col: warning[rule-id]: message`, or as
// JSON, or as SARIF 2.1.0 for code-scanning viewers. What `kiln lint` does is these calls (compiler/cli/lint_verb.cpp).
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "kiln/build.hpp"
#include "kiln/diagnostics.hpp"
#include "kiln/lint_rule_id.hpp"

namespace kiln {

// How a finding was suppressed (SARIF 2.1.0 suppression.kind): by a `// kiln-lint: ignore RULE` comment in the
// source (inSource), or by a rule list outside it: --disable, or the pack's "lint": {"disable": [...]} (external).
// A suppressed finding is still reported (SARIF `suppressions`, JSON `suppressed_findings`), never counted.
enum class Suppression : unsigned char { None, InSource, External };

struct LintFinding {
  RuleId rule = RuleId::BuildError;
  Severity severity = Severity::Warning;
  SourceLocation location;
  std::string message;
  std::vector<std::string> notes;
  // Other places the finding involves (the second declaration of a binding clash): a build's note diagnostics.
  std::vector<std::pair<SourceLocation, std::string>> related;
  Suppression suppression = Suppression::None;
  std::string justification;  // a suppression comment's text after `--`
};

struct LintReport {
  std::vector<LintFinding> findings;
  // Findings that are not suppressed, by severity; and the suppressed ones (which never fail --werror).
  int errors() const;
  int warnings() const;
  int suppressed() const;
};

// What lint leaves out: rules off for this run (--disable), on top of the pack's "lint": {"disable": [...]} and
// the sources' `// kiln-lint: ignore` comments.
struct LintOptions {
  std::vector<RuleId> disabled;
};

// Lints a pack definition: builds it into options.output_dir (a scratch directory), observes the build's plan
// and its outputs, and runs every rule.
LintReport lint_pack(BuildOptions options, const LintOptions& lint = {});
// Lints loose HLSL files with the source rules (undeclared keywords, fp16 guards). Each file's includes are
// read (next to the including file, then in `include_dirs`, confined to those roots), so keywords declared and
// names defined in included headers are known; the included files are linted too. `defines` (-D) are defined, as
// in a build.
LintReport lint_files(const std::vector<std::filesystem::path>& files,
                      const std::vector<std::filesystem::path>& include_dirs = {}, const std::vector<Define>& defines = {},
                      const LintOptions& lint = {});

// `colour`: the build's diagnostic colours (ANSI), for a terminal (--color).
std::string format_lint_text(const LintReport& report, bool colour = false);
std::string format_lint_json(const LintReport& report);

struct SarifOptions {
  // Artifact URIs are relative to this directory (uriBaseId "%SRCROOT%"); a file outside it keeps an absolute
  // file: URI. Empty: the current directory.
  std::filesystem::path root;
};
std::string format_lint_sarif(const LintReport& report, const SarifOptions& options = {});

// The default --sarif-root: the git work tree containing `directory` (the nearest ancestor with a .git
// entry), else `directory` itself.
std::filesystem::path default_sarif_root(const std::filesystem::path& directory);

}  // namespace kiln
