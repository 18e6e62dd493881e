// SPDX-License-Identifier: Apache-2.0
#include "lint/lint.hpp"

#include <algorithm>
#include <cstdlib>
#include <map>
#include <regex>
#include <set>

#include <nlohmann/json.hpp>

#include "common/files.hpp"
#include "declarations/declarations.hpp"
#include "kiln/pack_reader.hpp"
#include "kiln/manifest_json.hpp"

namespace kiln {
namespace {

using nlohmann::json;

bool available(const LintContext& context, LintInput need) {
  switch (need) {
    case LintInput::Sources: return true;
    case LintInput::Plan: return context.plan != nullptr;
    case LintInput::BuiltPack: return context.plan != nullptr && context.pack != nullptr;
    case LintInput::BuildDiagnostic: return false;
  }
  return false;
}

void run_rules_needing(const LintContext& context, LintInput need, LintReport& report) {
  if (!available(context, need)) return;
  for (const LintRule* rule : lint_rules())
    if (rule->input == need && rule->check) rule->check(context, report);
}

std::vector<std::string> declared_keywords(const std::vector<std::pair<std::string, std::vector<KeywordGroup>>>& pass_groups) {
  std::vector<std::string> declared;
  for (const auto& [pass, groups] : pass_groups)
    for (const KeywordGroup& group : groups)
      for (const std::string& value : group.values)
        if (!value.empty()) declared.push_back(value);
  std::sort(declared.begin(), declared.end());
  declared.erase(std::unique(declared.begin(), declared.end()), declared.end());
  return declared;
}

// A finding with no line is about a pass as a whole (an internal compiler error, a stage that failed, an
// interface): it is shown at the pass's definition in the pack file, so that every finding has a place (SARIF
// viewers need a region). The file it was reported in stays as a note.
void locate_pass_level_findings(const LintContext& context, LintReport& report) {
  static const std::regex pass_name(R"(pass '([^']*)')");
  for (LintFinding& f : report.findings) {
    if (f.location.line > 0) continue;
    std::smatch m;
    if (!std::regex_search(f.message, m, pass_name)) continue;
    SourceLocation at = context.pass_location(m[1]);
    if (at.line <= 0) continue;
    if (!f.location.path.empty() && f.location.path != at.path) f.notes.push_back("reported for '" + f.location.path + "'");
    f.location = at;
  }
}

// `// kiln-lint: ignore[-next-line] [RULE[,RULE...]] [-- why]` (clang-tidy's NOLINT and NOLINTNEXTLINE): the
// findings of those rules (of every rule, with no list) on that line, or on the next one.
struct SuppressionComment {
  bool every_rule = false;  // no list
  std::set<RuleId> rules;
  std::string justification;
};

void read_suppression_comments(const LintContext& context, std::map<std::pair<std::string, int>, SuppressionComment>& at,
                               LintReport& report) {
  static const std::regex comment_re(
      R"(//\s*kiln-lint:\s*(ignore-next-line|ignore)\b(?:[ \t]+([a-z0-9][a-z0-9-]*(?:[ \t]*,[ \t]*[a-z0-9][a-z0-9-]*)*))?(?:[ \t]+(?:--[ \t]*)?(.*?))?\s*$)");
  static const std::regex rule_re(R"([a-z0-9][a-z0-9-]*)");
  const std::vector<std::string> rule_ids(kRuleIdTexts.begin(), kRuleIdTexts.end());
  for (const auto& [path, text] : context.sources) {
    if (text.find("kiln-lint:") == std::string::npos) continue;
    const std::vector<std::string> lines = raw_lines(text);
    for (size_t i = 0; i < lines.size(); ++i) {
      std::smatch m;
      if (lines[i].find("kiln-lint:") == std::string::npos || !std::regex_search(lines[i], m, comment_re)) continue;
      const int line = static_cast<int>(i + 1) + (m.str(1) == "ignore-next-line" ? 1 : 0);
      SuppressionComment& comment = at[{path, line}];
      comment.justification = m.str(3);
      const std::string list = m.str(2);
      comment.every_rule = list.empty();
      for (auto it = std::sregex_iterator(list.begin(), list.end(), rule_re); it != std::sregex_iterator(); ++it) {
        if (std::optional<RuleId> rule = parse_rule_id(it->str())) {
          comment.rules.insert(*rule);
          continue;
        }
        // A misspelt rule would suppress nothing, silently.
        std::vector<std::string> notes;
        if (auto suggestion = closest_match(it->str(), rule_ids)) notes.push_back("did you mean '" + *suggestion + "'?");
        report.findings.push_back({RuleId::BuildError, Severity::Warning,
                                   SourceLocation{path, static_cast<int>(i + 1), static_cast<int>(m.position(2) + it->position()) + 1},
                                   "unknown lint rule '" + it->str() + "' in a kiln-lint comment", notes});
      }
    }
  }
}

// Marks the findings a rule list (--disable, the pack's "lint") or a comment suppresses; they stay in the report.
void apply_suppressions(const LintContext& context, const std::vector<RuleId>& disabled, LintReport& report) {
  std::map<std::pair<std::string, int>, SuppressionComment> comments;
  read_suppression_comments(context, comments, report);
  for (LintFinding& f : report.findings) {
    if (std::find(disabled.begin(), disabled.end(), f.rule) != disabled.end()) {
      f.suppression = Suppression::External;
      continue;
    }
    auto comment = comments.find({f.location.path, f.location.line});
    if (f.location.line <= 0 || comment == comments.end()) continue;
    if (comment->second.every_rule || comment->second.rules.count(f.rule)) {
      f.suppression = Suppression::InSource;
      f.justification = comment->second.justification;
    }
  }
}

// Keywords a pragma declares in the shaders under the pack's include roots that the build did not read: the
// library a shared header belongs to. Its header may test an option that another of its shaders declares
// (shaderlib/Common.hlsl's _HALF_PRECISION in variants/debug.pack.json); a name no shader declares is still a
// typo. Bounded: shader files only, no links followed, at most kMaxLibraryFiles files of the read limit each.
std::vector<std::string> library_keywords(const std::vector<std::filesystem::path>& roots, const LintContext& context) {
  constexpr size_t kMaxLibraryFiles = 4096;
  constexpr int kMaxLibraryDepth = 16;
  static const std::regex pragma_re(R"(^(\s*#\s*pragma)(.*)$)");
  const ReadLimits limits{};
  std::set<std::string> seen, keywords;
  size_t files = 0;
  for (const std::filesystem::path& root : roots) {
    std::error_code ec;
    auto it = std::filesystem::recursive_directory_iterator(root, std::filesystem::directory_options::skip_permission_denied, ec);
    for (; !ec && it != std::filesystem::recursive_directory_iterator() && files < kMaxLibraryFiles; it.increment(ec)) {
      if (it.depth() >= kMaxLibraryDepth) it.disable_recursion_pending();
      const std::filesystem::path& path = it->path();
      const std::string extension = path.extension().string();
      if (!it->is_regular_file(ec) || it->is_symlink(ec) ||
          (extension != ".hlsl" && extension != ".hlsli" && extension != ".fx" && extension != ".fxh" && extension != ".cginc"))
        continue;
      std::error_code canonical_ec;
      const std::filesystem::path canonical = std::filesystem::weakly_canonical(path, canonical_ec);
      if (!seen.insert(canonical_ec ? path.string() : canonical.string()).second) continue;
      ++files;
      DiagnosticSink quiet;  // a library file that cannot be read declares nothing; it is not this pack's finding
      std::optional<std::string> text = read_text_file(path, limits, quiet, SourceLocation{});
      if (!text || text->find("pragma") == std::string::npos) continue;
      const std::vector<std::string> lines = code_lines(*text);
      for (size_t i = 0; i < lines.size(); ++i) {
        std::smatch m;
        if (!std::regex_match(lines[i], m, pragma_re)) continue;
        if (auto parsed = parse_keyword_pragma(m.str(2), SourceLocation{path.string(), static_cast<int>(i + 1), 1}, 1); parsed && *parsed)
          for (const std::string& value : (*parsed)->values)
            if (!value.empty()) keywords.insert(value);
      }
    }
  }
  for (const std::string& keyword : context.declared) keywords.erase(keyword);
  return {keywords.begin(), keywords.end()};
}

}  // namespace

int LintReport::errors() const {
  return static_cast<int>(std::count_if(findings.begin(), findings.end(), [](const LintFinding& f) {
    return f.suppression == Suppression::None && f.severity == Severity::Error;
  }));
}
int LintReport::warnings() const {
  return static_cast<int>(std::count_if(findings.begin(), findings.end(), [](const LintFinding& f) {
    return f.suppression == Suppression::None && f.severity == Severity::Warning;
  }));
}
int LintReport::suppressed() const {
  return static_cast<int>(std::count_if(findings.begin(), findings.end(), [](const LintFinding& f) { return f.suppression != Suppression::None; }));
}

RuleId rule_for_diagnostic(DiagId id) {
  for (const LintRule* rule : lint_rules())
    if (rule->input == LintInput::BuildDiagnostic && rule->diagnostic == id) return rule->id;
  return RuleId::BuildError;
}

void run_lint_rules(const LintContext& context, LintReport& report) {
  for (LintInput need : {LintInput::Sources, LintInput::Plan, LintInput::BuiltPack}) run_rules_needing(context, need, report);
}

LintReport lint_pack(BuildOptions options, const LintOptions& lint) {
  LintReport report;
  DiagnosticSink sink;
  options.keep_plan = true;  // the rules observe this build's plan: nothing is planned twice
  BuildReport build = build_pack(options, sink);
  for (const Diagnostic& d : sink.diagnostics()) {
    // Lint judges the shaders, not the machine: a cache that cannot be written is not a finding (--werror
    // failed on it alone).
    if (d.id == DiagId::CacheUnwritable) continue;
    // A located note belongs to the finding before it (K1406's "'s' (sampler) is declared here").
    if (d.severity == Severity::Note) {
      if (!report.findings.empty()) report.findings.back().related.emplace_back(d.location, d.message);
      continue;
    }
    report.findings.push_back({rule_for_diagnostic(d.id), d.severity == Severity::Error ? Severity::Error : Severity::Warning,
                               d.location, d.message, d.notes});
  }
  std::vector<RuleId> disabled = lint.disabled;
  LintContext context;
  if (!build.plan) {
    apply_suppressions(context, disabled, report);
    return report;
  }
  for (const std::string& rule : build.plan->lint_disable)  // checked when the pack was read
    if (std::optional<RuleId> id = parse_rule_id(rule)) disabled.push_back(*id);
  context.plan = &*build.plan;
  context.sources = build.plan->sources;
  context.declared = declared_keywords(build.plan->pass_groups);
  for (const PassSettings& pass : build.plan->pass_settings)  // with the command line's -D applied
    for (const Define& define : pass.defines) context.defined.push_back(define.name);
  context.pack_file = display_path(options.pack_file);
  context.library_declared = library_keywords(build.plan->include_dirs, context);
  run_rules_needing(context, LintInput::Sources, report);
  run_rules_needing(context, LintInput::Plan, report);
  if (build.ok) {
    try {
      PackReader pack = PackReader::open(build.manifest, PackReader::Check::Full);
      PackView view = read_pack_view(pack);
      context.pack = &view;
      run_rules_needing(context, LintInput::BuiltPack, report);
      context.pack = nullptr;
    } catch (const PackError& error) {
      add_finding(report, RuleId::BuildError, SourceLocation{build.manifest.string(), 0, 0}, error.what());
    }
  }
  locate_pass_level_findings(context, report);
  apply_suppressions(context, disabled, report);
  return report;
}

LintReport lint_files(const std::vector<std::filesystem::path>& files, const std::vector<std::filesystem::path>& include_dirs,
                      const std::vector<Define>& defines, const LintOptions& lint) {
  LintReport report;
  DiagnosticSink sink;
  const ReadLimits limits{};
  // Each file's includes resolve next to the including file, then in the -I roots, confined to those roots
  // (the pack build's includer).
  std::vector<std::filesystem::path> roots = include_dirs;
  for (const auto& file : files) roots.push_back(file.parent_path().empty() ? std::filesystem::path(".") : file.parent_path());
  const IncludeRoots include_roots(roots);
  SourceSet read;
  std::vector<std::pair<std::filesystem::path, std::string>> shown;  // canonical -> display name, files first
  for (const auto& file : files) {
    std::error_code ec;
    std::filesystem::path canonical = std::filesystem::weakly_canonical(file, ec);
    (void)scan_declarations(file, include_roots, limits, read, sink);  // what it read is in `read`
    if (read.find(ec ? file : canonical)) shown.emplace_back(ec ? file : canonical, display_path(file));
  }
  for (const auto& [path, source] : read.files)
    if (std::none_of(shown.begin(), shown.end(), [&](const auto& s) { return s.first == path; }))
      shown.emplace_back(path, display_path(path));

  // A file that cannot be read is an error; an include the roots do not hold is a warning (the file is linted
  // out of its build: pass its include roots with -I). Other declaration errors are kiln build's to report.
  for (const Diagnostic& d : sink.diagnostics()) {
    const bool include_problem = d.id == DiagId::IncludeNotFound || d.id == DiagId::IncludeEscapesRoot ||
                                 d.id == DiagId::IncludeTooDeep || d.id == DiagId::IncludeSyntax || d.id == DiagId::IncludeCycle;
    const bool unreadable = d.id == DiagId::FileUnreadable || d.id == DiagId::FileNotRegular || d.id == DiagId::FileTooLarge ||
                            d.id == DiagId::FileNotText;
    std::vector<std::string> notes = d.notes;  // a file's own directory is also a root: said once
    notes.erase(std::unique(notes.begin(), notes.end()), notes.end());
    if (unreadable) report.findings.push_back({RuleId::BuildError, Severity::Error, d.location, d.message, notes});
    else if (include_problem) report.findings.push_back({RuleId::BuildError, Severity::Warning, d.location, d.message, notes});
  }

  LintContext context;
  for (const Define& define : defines) context.defined.push_back(define.name);
  // Keywords declared by the files and everything they include, parsed as the build parses them.
  static const std::regex pragma_re(R"(^(\s*#\s*pragma)(.*)$)");
  for (const auto& [path, name] : shown) {
    const SourceFile* file = read.find(path);
    context.sources.emplace_back(name, file->text);
    std::vector<std::string> lines = code_lines(file->text);
    for (size_t i = 0; i < lines.size(); ++i) {
      std::smatch m;
      if (!std::regex_match(lines[i], m, pragma_re)) continue;
      const int column = static_cast<int>(m.length(1)) + 1;
      // A malformed pragma is kiln build's error, not a lint finding.
      if (auto parsed = parse_keyword_pragma(m.str(2), SourceLocation{name, static_cast<int>(i + 1), column}, column);
          parsed && *parsed)
        for (const std::string& value : (*parsed)->values)
          if (!value.empty()) context.declared.push_back(value);
    }
  }
  std::sort(context.declared.begin(), context.declared.end());
  context.declared.erase(std::unique(context.declared.begin(), context.declared.end()), context.declared.end());
  run_lint_rules(context, report);
  apply_suppressions(context, lint.disabled, report);
  return report;
}

namespace {

std::string format_location(const SourceLocation& at) {
  std::string where = at.path.empty() ? "kiln" : at.path;
  if (at.line > 0) where += ":" + std::to_string(at.line);
  if (at.line > 0 && at.column > 0) where += ":" + std::to_string(at.column);
  return where;
}

}  // namespace

std::string format_lint_text(const LintReport& report, bool colour) {
  // The build's diagnostic colours (format_diagnostic): bold location and message, red errors, magenta warnings,
  // cyan notes.
  const std::string bold = colour ? "\x1b[1m" : "", reset = colour ? "\x1b[0m" : "";
  const std::string note = colour ? "\x1b[1;36mnote:\x1b[0m" : "note:";
  std::string out;
  for (const LintFinding& f : report.findings) {
    if (f.suppression != Suppression::None) continue;  // counted in the summary line
    const bool error = f.severity == Severity::Error;
    out += bold + format_location(f.location) + ": " + (colour ? (error ? "\x1b[1;31m" : "\x1b[1;35m") : "") +
           (error ? "error" : "warning") + "[" + std::string(rule_id_text(f.rule)) + "]:" + reset + bold + " " + f.message + reset + "\n";
    for (const std::string& text : f.notes) out += "  " + note + " " + text + "\n";
    for (const auto& [place, message] : f.related) out += "  " + note + " " + format_location(place) + ": " + message + "\n";
  }
  return out;
}

std::string format_lint_json(const LintReport& report) {
  // Suppressed findings are listed apart: a consumer that reads "findings" sees what counts.
  json findings = json::array(), suppressed = json::array();
  for (const LintFinding& f : report.findings) {
    json related = json::array();
    for (const auto& [place, message] : f.related)
      related.push_back({{"path", place.path}, {"line", place.line}, {"column", place.column}, {"message", message}});
    json finding{{"rule", rule_id_text(f.rule)},
                 {"severity", f.severity == Severity::Error ? "error" : "warning"},
                 {"path", f.location.path},
                 {"line", f.location.line},
                 {"column", f.location.column},
                 {"message", f.message},
                 {"notes", f.notes},
                 {"related", related}};
    if (f.suppression == Suppression::None) {
      findings.push_back(std::move(finding));
      continue;
    }
    finding["suppression"] = f.suppression == Suppression::InSource ? "inSource" : "external";
    if (!f.justification.empty()) finding["justification"] = f.justification;
    suppressed.push_back(std::move(finding));
  }
  return json{{"findings", findings},
              {"errors", report.errors()},
              {"warnings", report.warnings()},
              {"suppressed", report.suppressed()},
              {"suppressed_findings", suppressed}}
             .dump(2) + "\n";
}

}  // namespace kiln
