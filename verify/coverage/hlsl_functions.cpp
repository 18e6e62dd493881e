// SPDX-License-Identifier: Apache-2.0
#include "coverage/hlsl_functions.hpp"

#include <algorithm>
#include <cctype>
#include <optional>

namespace kiln::render {
namespace {

bool identifier_start(char c) { return std::isalpha(static_cast<unsigned char>(c)) || c == '_'; }
bool identifier_part(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; }

// The text with comments, string and character literals and preprocessor lines turned into spaces; newlines stay,
// so that offsets keep their lines.
std::string code_only(std::string_view text) {
  std::string out(text);
  bool line_start = true;
  for (size_t i = 0; i < out.size();) {
    const char c = out[i];
    if (c == '\n') {
      line_start = true;
      ++i;
      continue;
    }
    if (line_start && c == '#') {  // a directive, with its backslash continuations
      for (; i < out.size() && out[i] != '\n'; ++i) {
        if (out[i] == '\\' && i + 1 < out.size() && out[i + 1] == '\n') out[i++] = ' ';  // keep the newline, go on
        else out[i] = ' ';
      }
      continue;
    }
    if (!std::isspace(static_cast<unsigned char>(c))) line_start = false;
    if (c == '/' && i + 1 < out.size() && out[i + 1] == '/') {
      for (; i < out.size() && out[i] != '\n'; ++i) out[i] = ' ';
      continue;
    }
    if (c == '/' && i + 1 < out.size() && out[i + 1] == '*') {
      const size_t end = out.find("*/", i + 2);
      const size_t stop = end == std::string::npos ? out.size() : end + 2;
      for (; i < stop; ++i)
        if (out[i] != '\n') out[i] = ' ';
      continue;
    }
    if (c == '"' || c == '\'') {
      out[i++] = ' ';
      for (; i < out.size() && out[i] != c && out[i] != '\n'; ++i) {
        if (out[i] == '\\' && i + 1 < out.size() && out[i + 1] != '\n') out[i++] = ' ';
        out[i] = ' ';
      }
      if (i < out.size() && out[i] == c) out[i++] = ' ';
      continue;
    }
    ++i;
  }
  return out;
}

struct Token {
  std::string_view text;  // an identifier, a number, or one punctuation character
  uint32_t line;
};

std::vector<Token> tokens_of(std::string_view code) {
  std::vector<Token> out;
  uint32_t line = 1;
  for (size_t i = 0; i < code.size();) {
    const char c = code[i];
    if (c == '\n') ++line;
    if (std::isspace(static_cast<unsigned char>(c))) {
      ++i;
      continue;
    }
    size_t end = i + 1;
    if (identifier_start(c) || std::isdigit(static_cast<unsigned char>(c)))
      while (end < code.size() && (identifier_part(code[end]) || code[end] == '.')) ++end;
    out.push_back({code.substr(i, end - i), line});
    i = end;
  }
  return out;
}

bool is_identifier(std::string_view token) { return !token.empty() && identifier_start(token[0]); }

// What a `{` opens, from the tokens before it since the last `;` or scope boundary.
struct Opening {
  enum Kind { Scope, Function, Other } kind = Other;
  std::string name;  // a scope's or a function's
  uint32_t line = 0;
};

Opening classify(const std::vector<Token>& header) {
  // Attributes ([numthreads(8, 8, 1)], [[vk::binding(0)]]) are skipped: bracket depth.
  std::vector<const Token*> top;  // the header's tokens outside brackets and parentheses, '(' kept
  int brackets = 0, parens = 0;
  for (const Token& t : header) {
    if (t.text == "[") ++brackets;
    else if (t.text == "]") brackets = std::max(0, brackets - 1);
    else if (brackets > 0) continue;
    else if (t.text == "(") {
      if (parens++ == 0) top.push_back(&t);
    } else if (t.text == ")") parens = std::max(0, parens - 1);
    else if (parens == 0) top.push_back(&t);
  }
  if (top.empty()) return {};
  size_t first = 0;
  while (first < top.size() && (top[first]->text == "typedef" || top[first]->text == "export")) ++first;
  if (first >= top.size()) return {};
  const std::string_view lead = top[first]->text;
  if (lead == "namespace" || lead == "struct" || lead == "class" || lead == "interface") {
    Opening scope{Opening::Scope, {}, top[first]->line};
    if (first + 1 < top.size() && is_identifier(top[first + 1]->text)) scope.name = std::string(top[first + 1]->text);
    return scope;
  }
  if (lead == "cbuffer" || lead == "tbuffer" || lead == "enum") return {};
  // `type name(`: the first parenthesis outside attributes, after a name that follows at least a type.
  for (size_t i = first; i < top.size(); ++i) {
    if (top[i]->text == "=") return {};  // an initializer: `static const float w[2] = {...}`
    if (top[i]->text != "(") continue;
    // The type's last token: a name, or the `>` of `vector<float, 4>`.
    if (i < first + 2 || !is_identifier(top[i - 1]->text) || !(is_identifier(top[i - 2]->text) || top[i - 2]->text == ">"))
      return {};
    return {Opening::Function, std::string(top[i - 1]->text), top[i - 1]->line};
  }
  return {};
}

}  // namespace

std::vector<HlslFunction> hlsl_functions(std::string_view text) {
  const std::string code = code_only(text);
  const std::vector<Token> tokens = tokens_of(code);
  struct Level {
    bool transparent;        // file, namespace or struct scope: definitions are looked for inside
    std::string prefix;      // "Surface::"
    std::optional<size_t> function;  // the record a function body's closing brace completes
  };
  std::vector<Level> levels{{true, {}, std::nullopt}};
  std::vector<HlslFunction> found;
  std::vector<bool> complete;
  std::vector<Token> header;
  for (const Token& t : tokens) {
    Level& here = levels.back();
    if (t.text == "{") {
      if (!here.transparent) {
        levels.push_back({false, {}, std::nullopt});
        continue;
      }
      const Opening opening = classify(header);
      header.clear();
      if (opening.kind == Opening::Scope) {
        levels.push_back({true, here.prefix + (opening.name.empty() ? "" : opening.name + "::"), std::nullopt});
      } else if (opening.kind == Opening::Function) {
        found.push_back({here.prefix + opening.name, opening.line, 0});
        complete.push_back(false);
        levels.push_back({false, {}, found.size() - 1});
      } else {
        levels.push_back({false, {}, std::nullopt});
      }
      continue;
    }
    if (t.text == "}") {
      if (levels.size() == 1) break;  // unbalanced: what came before stands
      if (levels.back().function) {
        found[*levels.back().function].last_line = t.line;
        complete[*levels.back().function] = true;
      }
      levels.pop_back();
      header.clear();
      continue;
    }
    if (!here.transparent) continue;
    if (t.text == ";") header.clear();
    else header.push_back(t);
  }
  std::vector<HlslFunction> out;
  for (size_t i = 0; i < found.size(); ++i)
    if (complete[i]) out.push_back(std::move(found[i]));
  std::stable_sort(out.begin(), out.end(), [](const HlslFunction& a, const HlslFunction& b) { return a.first_line < b.first_line; });
  return out;
}

}  // namespace kiln::render
