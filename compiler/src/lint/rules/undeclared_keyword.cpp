// SPDX-License-Identifier: Apache-2.0
// undeclared-keyword: a keyword-shaped name tested by #if/#ifdef that nothing declares or defines (a typo?).
#include <regex>
#include <set>

#include "common/files.hpp"
#include "declarations/declarations.hpp"
#include "lint/rules/rules.hpp"

namespace kiln::rules {
namespace {

void check_undeclared_keyword(const LintContext& context, LintReport& report) {
  // Names #define'd anywhere are the library's own macros, not keywords.
  static const std::regex define_re(R"(^\s*#\s*define\s+([A-Za-z_][A-Za-z0-9_]*))");
  static const std::regex test_re(R"(^\s*#\s*(if|ifdef|ifndef|elif)\b(.*)$)");
  static const std::regex name_re(R"([A-Za-z_][A-Za-z0-9_]*)");
  // Keyword-shaped: upper case, digits and underscores, at least 3 characters (Unity's convention).
  static const std::regex keyword_shape(R"(^_?[A-Z][A-Z0-9_]{2,}$)");
  // A shared header may test an option another shader of its library declares (an option this pack leaves off).
  std::vector<std::string> declared = context.declared;
  declared.insert(declared.end(), context.library_declared.begin(), context.library_declared.end());
  std::set<std::string> defined(declared.begin(), declared.end());
  defined.insert(context.defined.begin(), context.defined.end());  // the build's own defines (pack, pass, -D)
  // KILN_FOLDED_<K> and KILN_GROUP_OF_<K>: what kiln defines where a declared keyword K is folded
  // (kiln/folded_keywords.hpp), which a shader built both ways tests (docs/keywords.md).
  for (const std::string& keyword : declared) {
    defined.insert("KILN_FOLDED_" + keyword);
    defined.insert("KILN_GROUP_OF_" + keyword);
  }
  for (const auto& [path, text] : context.sources)
    for (const std::string& line : code_lines(text)) {
      std::smatch m;
      if (std::regex_search(line, m, define_re)) defined.insert(m[1]);
    }
  for (const auto& [path, text] : context.sources) {
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
        add_finding(report, RuleId::UndeclaredKeyword,
                    SourceLocation{path, static_cast<int>(i + 1), static_cast<int>(rest_offset + it->position()) + 1},
                    "'" + name + "' is tested here but no pragma declares it and nothing defines it", notes);
      }
    }
  }
}

}  // namespace

constinit const LintRule undeclared_keyword{
    RuleId::UndeclaredKeyword, "UndeclaredKeyword",
    "A keyword-like name tested by #if/#ifdef is never declared or defined (typo?).",
    "A name shaped like a keyword (_?[A-Z][A-Z0-9_]{2,}) tested by #if, #ifdef, #ifndef or #elif that no keyword "
    "pragma declares, no #define in any file read defines and no define of the build sets (the pack's and its "
    "passes' \"defines\", -D) is never true: usually a misspelt keyword. In pack mode a keyword that a shader under the "
    "pack's include directories declares is known too (a shared header tests an option of its library). The "
    "closest declared keyword is suggested. In file mode, pass the include roots with -I so that names defined "
    "in included headers are known.",
    Severity::Warning, LintInput::Sources, check_undeclared_keyword};

}  // namespace kiln::rules
