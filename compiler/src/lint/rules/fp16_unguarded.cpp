// SPDX-License-Identifier: Apache-2.0
// fp16-unguarded: division, pow, sqrt, rsqrt or normalize in 16-bit code with no visible guard.
#include <algorithm>
#include <regex>

#include "declarations/declarations.hpp"
#include "lint/rules/rules.hpp"

namespace kiln::rules {
namespace {

void check_fp16_unguarded(const LintContext& context, LintReport& report) {
  // Heuristics (documented in docs/lint.md): a line is fp16 code if it names `real` or `half`, or lies in the
  // body of a function whose declaration does; an operation is guarded if its line, or the line above, shows a
  // guard: max/clamp/saturate/Safe*/saturateMediump, or a comment that states the bound (floor, guard, never
  // zero, finite, >=).
  static const std::regex fp16_line(R"(\b(real[234]?|half[234]?)\b)");
  static const std::regex risky(R"((\bpow\s*\(|\bsqrt\s*\(|\brsqrt\s*\(|\bnormalize\s*\(|/\s*[A-Za-z_(]))");
  static const std::regex guard(R"((\bmax\s*\(|\bclamp\s*\(|\bsaturate|\bSafe[A-Za-z]*\s*\(|saturateMediump))");
  static const std::regex stated(R"(floor|guard|never zero|finite|>=|bounded)", std::regex::icase);
  for (const auto& [path, text] : context.sources) {
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
      op.erase(std::remove_if(op.begin(), op.end(), [](char c) { return c == ' ' || c == '('; }), op.end());
      if (!op.empty() && op[0] == '/') op = "/";
      add_finding(report, RuleId::Fp16Unguarded, SourceLocation{path, static_cast<int>(i + 1), static_cast<int>(m.position()) + 1},
                  "'" + op + "' on a 16-bit value with no visible guard: fp16 overflows above 65504 and has no denormal margin",
                  {"guard it (max, clamp, saturate, SafeNormalize) or state the bound in a comment on the line above"});
    }
  }
}

}  // namespace

constinit const LintRule fp16_unguarded{
    RuleId::Fp16Unguarded, "Fp16Unguarded",
    "Division, pow, sqrt, rsqrt or normalize of a 16-bit value with no visible guard.",
    "fp16 overflows above 65504 and has no denormal margin. In code that names real or half (or in the body of a "
    "function whose declaration does), a division, pow, sqrt, rsqrt or normalize must show a guard on its line "
    "or the line above (max, clamp, saturate, a Safe... function, saturateMediump) or a comment stating the bound "
    "(floor, guard, never zero, finite, bounded, >=). A heuristic: it insists that the reason be written down.",
    Severity::Warning, LintInput::Sources, check_fp16_unguarded};

}  // namespace kiln::rules
