#include "lint/lint.hpp"

#include <algorithm>
#include <map>
#include <regex>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

#include "common/files.hpp"
#include "declarations/declarations.hpp"
#include "kiln/pack_reader.hpp"

namespace kiln {
namespace {

using nlohmann::json;

const LintRule& rule(const std::string& id) {
  for (const LintRule& r : lint_rules())
    if (r.id == id) return r;
  static const LintRule unknown{"build-error", Severity::Error, "the build failed"};
  return unknown;
}

void add(LintReport& report, const std::string& id, SourceLocation at, std::string message, std::vector<std::string> notes = {}) {
  report.findings.push_back({id, rule(id).severity, std::move(at), std::move(message), std::move(notes)});
}

// Pipeline diagnostics that are lint findings of their own rule.
std::string rule_of(DiagId id) {
  switch (id) {
    case DiagId::BudgetExceeded: return "budget-exceeded";
    case DiagId::MissingEntryPoint: return "missing-entry-point";
    case DiagId::LayoutMismatch: return "layout-mismatch";
    case DiagId::SpirvInvalid: return "spirv-invalid";
    case DiagId::HlslWarning: return "hlsl-warning";
    default: return "build-error";
  }
}

std::vector<std::string> raw_lines(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

// Every keyword changes some compiled code: compare variants that differ only in that keyword.
void lint_unused_keywords(const PackReader& pack, const PlanListing& plan, LintReport& report) {
  const json& passes = pack.manifest().at("passes");
  for (size_t p = 0; p < passes.size() && p < plan.pass_groups.size(); ++p) {
    const json& variants = passes[p].at("variants");
    std::map<std::vector<std::string>, size_t> by_keywords;
    for (size_t i = 0; i < variants.size(); ++i) by_keywords[variants[i].at("keywords").get<std::vector<std::string>>()] = i;
    for (const KeywordGroup& group : plan.pass_groups[p].second) {
      for (const std::string& keyword : group.values) {
        if (keyword.empty()) continue;
        bool compared = false, changes = false;
        for (const auto& [keywords, index] : by_keywords) {
          if (std::find(keywords.begin(), keywords.end(), keyword) == keywords.end()) continue;
          std::vector<std::string> without;
          std::copy_if(keywords.begin(), keywords.end(), std::back_inserter(without), [&](const std::string& k) { return k != keyword; });
          auto other = by_keywords.find(without);
          if (other == by_keywords.end()) continue;
          compared = true;
          if (variants[index].at("binaries") != variants[other->second].at("binaries")) {
            changes = true;
            break;
          }
        }
        if (compared && !changes)
          add(report, "unused-keyword", group.declared_at,
              "keyword '" + keyword + "' changes no compiled code of pass '" + plan.pass_groups[p].first +
                  "': every variant with it is identical to the one without",
              {"remove it, or use it under #if defined(" + keyword + ")"});
      }
    }
  }
}

// Every fragment input is written by the vertex stage, with the same type.
void lint_interfaces(const PackReader& pack, const SourceLocation& at, LintReport& report) {
  const json& binaries = pack.manifest().at("binaries");
  const json& reflections = pack.manifest().at("reflections");
  std::set<std::pair<size_t, size_t>> checked;
  for (const json& pass : pack.manifest().at("passes")) {
    for (const json& variant : pass.at("variants")) {
      const json& stages = variant.at("binaries");
      if (!stages.contains("vertex") || !stages.contains("fragment")) continue;
      auto pair = std::make_pair(stages.at("vertex").get<size_t>(), stages.at("fragment").get<size_t>());
      if (!checked.insert(pair).second) continue;
      const json& outputs = reflections.at(binaries.at(pair.first).at("reflection").get<size_t>()).at("outputs");
      const json& inputs = reflections.at(binaries.at(pair.second).at("reflection").get<size_t>()).at("inputs");
      for (const json& input : inputs) {
        auto written = std::find_if(outputs.begin(), outputs.end(), [&](const json& o) { return o.at("location") == input.at("location"); });
        std::string keywords = join_keywords(variant.at("keywords").get<std::vector<std::string>>());
        if (written == outputs.end())
          add(report, "interface-mismatch", at,
              "pass '" + pass.at("name").get<std::string>() + "' [" + keywords + "]: fragment input '" +
                  input.at("name").get<std::string>() + "' at location " + input.at("location").dump() +
                  " is not written by the vertex stage");
        else if (written->at("type") != input.at("type"))
          add(report, "interface-mismatch", at,
              "pass '" + pass.at("name").get<std::string>() + "' [" + keywords + "]: location " + input.at("location").dump() +
                  " is " + written->at("type").get<std::string>() + " in the vertex stage and " +
                  input.at("type").get<std::string>() + " in the fragment stage");
      }
    }
  }
}

void lint_scene_variation(const PlanListing& plan, LintReport& report) {
  if (plan.scenes.empty()) return;
  std::set<const KeywordGroup*> seen;
  for (const auto& [pass, groups] : plan.pass_groups) {
    for (const KeywordGroup& group : groups) {
      if (group.material_feature) continue;
      bool varied = false;
      for (const auto& [scene, keywords] : plan.scenes)
        for (const std::string& value : group.values)
          if (!value.empty() && keywords.count(value)) varied = true;
      if (!varied)
        add(report, "multi-compile-could-be-feature", group.declared_at,
            "no scene enables any keyword of '#pragma " + group.pragma + "' (pass '" + pass +
                "'): declare it with shader_feature so that only materials that use it pay for it, or remove it");
    }
  }
}

}  // namespace

const std::vector<LintRule>& lint_rules() {
  static const std::vector<LintRule> rules{
      {"unused-keyword", Severity::Warning, "a declared keyword changes no stage's compiled code"},
      {"undeclared-keyword", Severity::Warning, "a keyword-like name tested by #if/#ifdef is never declared or defined (typo?)"},
      {"multi-compile-could-be-feature", Severity::Warning, "no scene varies a multi_compile group: shader_feature would strip it"},
      {"budget-exceeded", Severity::Error, "the pack has more variants than its budget"},
      {"missing-entry-point", Severity::Error, "a stage's entry point does not exist"},
      {"interface-mismatch", Severity::Error, "a fragment input is not written by the vertex stage, or with another type"},
      {"layout-mismatch", Severity::Error, "descriptor layouts differ between variants or stages of a pass"},
      {"spirv-invalid", Severity::Error, "spirv-val rejected a module"},
      {"fp16-unguarded", Severity::Warning, "division, pow, sqrt or normalize of a 16-bit value with no visible guard"},
      {"hlsl-warning", Severity::Warning, "the HLSL front end warned"},
      {"build-error", Severity::Error, "any other error of the build"},
  };
  return rules;
}

int LintReport::errors() const {
  return static_cast<int>(std::count_if(findings.begin(), findings.end(), [](const LintFinding& f) { return f.severity == Severity::Error; }));
}
int LintReport::warnings() const {
  return static_cast<int>(std::count_if(findings.begin(), findings.end(), [](const LintFinding& f) { return f.severity == Severity::Warning; }));
}

void lint_undeclared_keywords(const std::vector<std::pair<std::string, std::string>>& sources,
                              const std::vector<std::string>& declared, LintReport& report) {
  // Names #define'd anywhere are the library's own macros, not keywords.
  static const std::regex define_re(R"(^\s*#\s*define\s+([A-Za-z_][A-Za-z0-9_]*))");
  static const std::regex test_re(R"(^\s*#\s*(if|ifdef|ifndef|elif)\b(.*)$)");
  static const std::regex name_re(R"([A-Za-z_][A-Za-z0-9_]*)");
  // Keyword-shaped: upper case, digits and underscores, at least 3 characters (Unity's convention).
  static const std::regex keyword_shape(R"(^_?[A-Z][A-Z0-9_]{2,}$)");
  std::set<std::string> defined(declared.begin(), declared.end());
  for (const auto& [path, text] : sources)
    for (const std::string& line : code_lines(text)) {
      std::smatch m;
      if (std::regex_search(line, m, define_re)) defined.insert(m[1]);
    }
  for (const auto& [path, text] : sources) {
    std::vector<std::string> lines = code_lines(text);
    for (size_t i = 0; i < lines.size(); ++i) {
      std::smatch m;
      if (!std::regex_match(lines[i], m, test_re)) continue;
      std::string rest = m[2];
      size_t rest_offset = static_cast<size_t>(m.position(2));
      for (auto it = std::sregex_iterator(rest.begin(), rest.end(), name_re); it != std::sregex_iterator(); ++it) {
        std::string name = it->str();
        if (name == "defined" || !std::regex_match(name, keyword_shape) || defined.count(name)) continue;
        std::vector<std::string> notes;
        if (auto suggestion = closest_match(name, declared)) notes.push_back("did you mean '" + *suggestion + "'?");
        add(report, "undeclared-keyword", SourceLocation{path, static_cast<int>(i + 1), static_cast<int>(rest_offset + it->position()) + 1},
            "'" + name + "' is tested here but no pragma declares it and nothing defines it", notes);
      }
    }
  }
}

void lint_fp16_guards(const std::vector<std::pair<std::string, std::string>>& sources, LintReport& report) {
  // Heuristics (documented in docs/lint.md): a line is fp16 code if it names `real` or `half`, or lies in the
  // body of a function whose declaration does; an operation
  // is guarded if its line, or the line above, shows a guard: max/clamp/saturate/Safe*/saturateMediump, or a
  // comment that states the bound (floor, guard, never zero, finite, >=).
  static const std::regex fp16_line(R"(\b(real[234]?|half[234]?)\b)");
  static const std::regex risky(R"((\bpow\s*\(|\bsqrt\s*\(|\brsqrt\s*\(|\bnormalize\s*\(|/\s*[A-Za-z_(]))");
  static const std::regex guard(R"((\bmax\s*\(|\bclamp\s*\(|\bsaturate|\bSafe[A-Za-z]*\s*\(|saturateMediump))");
  static const std::regex stated(R"(floor|guard|never zero|finite|>=|bounded)", std::regex::icase);
  for (const auto& [path, text] : sources) {
    std::vector<std::string> code = code_lines(text);
    std::vector<std::string> raw = raw_lines(text);
    // The body of a function whose declaration names a 16-bit type is 16-bit code throughout.
    int depth = 0;
    bool declaration_fp16 = false, body_fp16 = false;
    for (size_t i = 0; i < code.size(); ++i) {
      bool line_fp16 = std::regex_search(code[i], fp16_line);
      if (depth == 0 && line_fp16) declaration_fp16 = true;
      bool in_fp16_body = body_fp16;
      for (char c : code[i]) {
        if (c == '{' && depth++ == 0) {
          body_fp16 = declaration_fp16;
          in_fp16_body = in_fp16_body || body_fp16;
        } else if (c == '}' && depth > 0 && --depth == 0) {
          body_fp16 = declaration_fp16 = false;
        } else if (c == ';' && depth == 0) {
          declaration_fp16 = false;
        }
      }
      if (!line_fp16 && !in_fp16_body) continue;
      std::smatch m;
      if (!std::regex_search(code[i], m, risky)) continue;
      bool guarded = std::regex_search(code[i], guard) ||
                     (i > 0 && (std::regex_search(code[i - 1], guard) || std::regex_search(raw[i - 1], stated))) ||
                     (i < raw.size() && std::regex_search(raw[i], stated));
      if (guarded) continue;
      std::string op = m.str();
      op.erase(std::remove_if(op.begin(), op.end(), [](char c) { return c == ' ' || c == '(' ; }), op.end());
      if (!op.empty() && op[0] == '/') op = "/";
      add(report, "fp16-unguarded", SourceLocation{path, static_cast<int>(i + 1), static_cast<int>(m.position()) + 1},
          "'" + op + "' on a 16-bit value with no visible guard: fp16 overflows above 65504 and has no denormal margin",
          {"guard it (max, clamp, saturate, SafeNormalize) or state the bound in a comment on the line above"});
    }
  }
}

LintReport lint_pack(const BuildOptions& options) {
  LintReport report;
  DiagnosticSink sink;
  BuildReport build = build_pack(options, sink);
  for (const Diagnostic& d : sink.diagnostics()) {
    // Lint judges the shaders, not the machine: a cache that cannot be written is not a finding (--werror
    // failed on it alone).
    if (d.severity == Severity::Note || d.id == DiagId::CacheUnwritable) continue;
    report.findings.push_back({rule_of(d.id), d.severity == Severity::Error ? Severity::Error : Severity::Warning,
                               d.location, d.message, d.notes});
  }
  DiagnosticSink plan_sink;
  auto plan = list_variants(options, plan_sink);
  if (!plan) return report;
  std::vector<std::string> declared;
  for (const auto& [pass, groups] : plan->pass_groups)
    for (const KeywordGroup& group : groups)
      for (const std::string& value : group.values)
        if (!value.empty()) declared.push_back(value);
  std::sort(declared.begin(), declared.end());
  declared.erase(std::unique(declared.begin(), declared.end()), declared.end());
  lint_undeclared_keywords(plan->sources, declared, report);
  lint_fp16_guards(plan->sources, report);
  lint_scene_variation(*plan, report);
  if (build.ok) {
    try {
      PackReader pack = PackReader::open(build.manifest);
      lint_unused_keywords(pack, *plan, report);
      lint_interfaces(pack, SourceLocation{options.pack_file.string(), 0, 0}, report);
    } catch (const PackError& error) {
      add(report, "build-error", SourceLocation{build.manifest.string(), 0, 0}, error.what());
    }
  }
  return report;
}

LintReport lint_files(const std::vector<std::filesystem::path>& files) {
  LintReport report;
  std::vector<std::pair<std::string, std::string>> sources;
  std::vector<std::string> declared;
  DiagnosticSink sink;
  for (const auto& file : files) {
    auto text = read_text_file(file, ReadLimits{}, sink, SourceLocation{display_path(file), 0, 0});
    if (!text) continue;
    sources.emplace_back(display_path(file), *text);
    // Keywords declared by the files themselves.
    static const std::regex pragma_re(R"(^\s*#\s*pragma\s+(multi_compile\w*|shader_feature\w*)\s+(.*)$)");
    for (const std::string& line : code_lines(*text)) {
      std::smatch m;
      if (!std::regex_match(line, m, pragma_re)) continue;
      std::istringstream words(m[2].str());
      for (std::string w; words >> w;)
        if (w.find_first_not_of('_') != std::string::npos) declared.push_back(w);
      if (m[1] == "multi_compile_fog")
        for (const char* fog : {"FOG_LINEAR", "FOG_EXP", "FOG_EXP2"}) declared.push_back(fog);
    }
  }
  for (const Diagnostic& d : sink.diagnostics()) report.findings.push_back({"build-error", Severity::Error, d.location, d.message, d.notes});
  lint_undeclared_keywords(sources, declared, report);
  lint_fp16_guards(sources, report);
  return report;
}

std::string format_lint_text(const LintReport& report) {
  std::string out;
  for (const LintFinding& f : report.findings) {
    const SourceLocation& at = f.location;
    std::string where = at.path.empty() ? "kiln" : at.path;
    if (at.line > 0) where += ":" + std::to_string(at.line);
    if (at.line > 0 && at.column > 0) where += ":" + std::to_string(at.column);
    out += where + ": " + (f.severity == Severity::Error ? "error" : "warning") + "[" + f.rule + "]: " + f.message + "\n";
    for (const std::string& note : f.notes) out += "  note: " + note + "\n";
  }
  return out;
}

std::string format_lint_json(const LintReport& report) {
  json findings = json::array();
  for (const LintFinding& f : report.findings)
    findings.push_back({{"rule", f.rule},
                        {"severity", f.severity == Severity::Error ? "error" : "warning"},
                        {"path", f.location.path},
                        {"line", f.location.line},
                        {"column", f.location.column},
                        {"message", f.message},
                        {"notes", f.notes}});
  return json{{"findings", findings}, {"errors", report.errors()}, {"warnings", report.warnings()}}.dump(2) + "\n";
}

std::string format_lint_sarif(const LintReport& report) {
  json rules = json::array();
  for (const LintRule& r : lint_rules())
    rules.push_back({{"id", r.id},
                     {"shortDescription", {{"text", r.description}}},
                     {"defaultConfiguration", {{"level", r.severity == Severity::Error ? "error" : "warning"}}}});
  json results = json::array();
  for (const LintFinding& f : report.findings) {
    std::string message = f.message;
    for (const std::string& note : f.notes) message += " (" + note + ")";
    json result{{"ruleId", f.rule}, {"level", f.severity == Severity::Error ? "error" : "warning"}, {"message", {{"text", message}}}};
    if (!f.location.path.empty()) {
      json region = json::object();
      if (f.location.line > 0) region["startLine"] = f.location.line;
      if (f.location.column > 0) region["startColumn"] = f.location.column;
      json physical{{"artifactLocation", {{"uri", f.location.path}}}};
      if (!region.empty()) physical["region"] = region;
      result["locations"] = json::array({{{"physicalLocation", physical}}});
    }
    results.push_back(result);
  }
  json sarif{{"$schema", "https://json.schemastore.org/sarif-2.1.0.json"},
             {"version", "2.1.0"},
             {"runs", json::array({{{"tool", {{"driver", {{"name", "kiln"},
                                                           {"version", kKilnVersion},
                                                           {"rules", rules}}}}},
                                    {"results", results}}})}};
  return sarif.dump(2) + "\n";
}

}  // namespace kiln
