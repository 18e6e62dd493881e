// SPDX-License-Identifier: Apache-2.0
// SARIF 2.1.0 output, for GitHub code scanning and other SARIF viewers: the rule table with descriptions and
// help into docs/lint.md, one result per finding with a region, artifact URIs relative to a root
// (`originalUriBaseIds`), percent-encoded.
#include <cstdio>

#include <nlohmann/json.hpp>

#include "lint/lint.hpp"

#ifndef KILN_LINT_DOCS_URL
#define KILN_LINT_DOCS_URL ""
#endif
#ifndef KILN_INSTALLED_DOC_DIR
#define KILN_INSTALLED_DOC_DIR "share/doc/kiln"
#endif
#ifndef KILN_SOURCE_LINT_DOC
#define KILN_SOURCE_LINT_DOC "docs/lint.md"
#endif

namespace kiln {
namespace {

using nlohmann::json;

constexpr const char* kRootId = "%SRCROOT%";

// RFC 3986: a path keeps its unreserved characters and '/'; every other byte is %XX.
std::string percent_encode_path(const std::string& path) {
  std::string out;
  for (unsigned char c : path) {
    const bool keep = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-' ||
                      c == '.' || c == '_' || c == '~' || c == '/';
    if (keep) {
      out += static_cast<char>(c);
    } else {
      char hex[4];
      std::snprintf(hex, sizeof hex, "%%%02X", c);
      out += hex;
    }
  }
  return out;
}

std::string file_uri(const std::filesystem::path& absolute, bool directory) {
  std::string path = absolute.generic_string();
  if (directory && (path.empty() || path.back() != '/')) path += '/';
  return "file://" + percent_encode_path(path);
}

// The configured URL; else the lint.md installed beside the running kiln (<prefix>/bin/kiln ->
// <prefix>/share/doc/kiln/lint.md); else the source tree's, for a kiln run from its build tree.
std::string docs_url() {
  const std::string configured = KILN_LINT_DOCS_URL;
  if (!configured.empty())
    return configured.rfind("file://", 0) == 0 ? "file://" + percent_encode_path(configured.substr(7)) : configured;
  std::error_code ec;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const std::filesystem::path installed = self.parent_path().parent_path() / KILN_INSTALLED_DOC_DIR / "lint.md";
    if (std::filesystem::is_regular_file(installed, ec)) return file_uri(installed.lexically_normal(), false);
  }
  return file_uri(std::filesystem::path(KILN_SOURCE_LINT_DOC), false);
}

json artifact_location(const std::string& path, const std::filesystem::path& root) {
  std::error_code ec;
  const std::filesystem::path absolute = std::filesystem::absolute(path, ec).lexically_normal();
  const std::filesystem::path relative = absolute.lexically_relative(root);
  if (!ec && !relative.empty() && *relative.begin() != "..")
    return {{"uri", percent_encode_path(relative.generic_string())}, {"uriBaseId", kRootId}};
  return {{"uri", file_uri(absolute, false)}};
}

const char* level(Severity severity) { return severity == Severity::Error ? "error" : "warning"; }

// Every location has a region: one about a whole file (no line) points at its first line.
json physical_location(const SourceLocation& at, const std::filesystem::path& root) {
  json region{{"startLine", at.line > 0 ? at.line : 1}};
  if (at.line > 0 && at.column > 0) region["startColumn"] = at.column;
  return {{"artifactLocation", artifact_location(at.path, root)}, {"region", region}};
}

}  // namespace

std::filesystem::path default_sarif_root(const std::filesystem::path& directory) {
  std::error_code ec;
  const std::filesystem::path start = std::filesystem::absolute(directory, ec).lexically_normal();
  for (std::filesystem::path dir = start;; dir = dir.parent_path()) {
    if (std::filesystem::exists(dir / ".git", ec)) return dir;  // a directory, or a worktree's .git file
    if (dir == dir.root_path() || dir.parent_path() == dir) break;
  }
  return start;
}

std::string format_lint_sarif(const LintReport& report, const SarifOptions& options) {
  std::error_code ec;
  std::filesystem::path root = options.root.empty() ? std::filesystem::current_path(ec) : options.root;
  root = std::filesystem::absolute(root, ec).lexically_normal();
  if (root.has_filename() == false && root != root.root_path()) root = root.parent_path();  // no trailing '/'

  json rules = json::array();
  for (const LintRule* r : lint_rules()) {
    const std::string id(r->id_text());
    const std::string help_uri = docs_url() + "#" + std::string(r->help_anchor());
    rules.push_back({{"id", id},
                     {"name", r->name},
                     {"shortDescription", {{"text", r->short_description}}},
                     {"fullDescription", {{"text", r->full_description}}},
                     {"help", {{"text", std::string(r->full_description) + " See docs/lint.md#" + id + "."},
                               {"markdown", std::string(r->full_description) + " See [docs/lint.md](" + help_uri + ")."}}},
                     {"helpUri", help_uri},
                     {"defaultConfiguration", {{"level", level(r->severity)}}}});
  }
  json results = json::array();
  for (const LintFinding& f : report.findings) {
    std::string message = f.message;
    for (const std::string& note : f.notes) message += " (" + note + ")";
    json result{{"ruleId", rule_id_text(f.rule)},
                {"ruleIndex", static_cast<int>(f.rule)},
                {"level", level(f.severity)},
                {"message", {{"text", message}}}};
    if (!f.location.path.empty()) result["locations"] = json::array({{{"physicalLocation", physical_location(f.location, root)}}});
    json related = json::array();
    for (const auto& [place, text] : f.related) {
      if (place.path.empty()) continue;
      related.push_back({{"id", static_cast<int>(related.size())},
                         {"physicalLocation", physical_location(place, root)},
                         {"message", {{"text", text}}}});
    }
    if (!related.empty()) result["relatedLocations"] = related;
    // SARIF 2.1.0 §3.35: a suppressed result is still a result, so that a viewer can show what was silenced.
    if (f.suppression != Suppression::None) {
      json suppression{{"kind", f.suppression == Suppression::InSource ? "inSource" : "external"}};
      if (!f.justification.empty()) suppression["justification"] = f.justification;
      result["suppressions"] = json::array({suppression});
    }
    results.push_back(result);
  }
  json run{{"tool", {{"driver", {{"name", "kiln"},
                                 {"version", kKilnVersion},
                                 {"informationUri", docs_url()},
                                 {"rules", rules}}}}},
           {"originalUriBaseIds", {{kRootId, {{"uri", file_uri(root, true)}}}}},
           {"results", results}};
  json sarif{{"$schema", "https://json.schemastore.org/sarif-2.1.0.json"}, {"version", "2.1.0"}, {"runs", json::array({run})}};
  return sarif.dump(2) + "\n";
}

}  // namespace kiln
