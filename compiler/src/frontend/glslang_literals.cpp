// SPDX-License-Identifier: Apache-2.0
#include "frontend/glslang_literals.hpp"

#include <cstdint>
#include <utility>

namespace kiln {
namespace {

constexpr std::string_view kStringMarker = "__kiln_lit_";

bool is_identifier_char(char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_';
}

// Where a backslash-newline (line continuation) starting at `at` ends, or `at` if there is none.
size_t after_continuation(std::string_view text, size_t at) {
  if (at >= text.size() || text[at] != '\\') return at;
  if (at + 1 < text.size() && text[at + 1] == '\n') return at + 2;
  if (at + 2 < text.size() && text[at + 1] == '\r' && text[at + 2] == '\n') return at + 3;
  return at;
}

// The value glslang's scanner gives the character literal at `at` (text[at] == '\'') and the literal's
// length; nothing where glslang reports an error (left for glslang to report) or would read past a line.
std::optional<std::pair<int, size_t>> character_literal(std::string_view text, size_t at) {
  auto plain = [](unsigned char c) { return c >= 0x20 && c < 0x7F; };
  if (at + 2 >= text.size()) return std::nullopt;
  const unsigned char first = static_cast<unsigned char>(text[at + 1]);
  int value = 0;
  size_t close = at + 2;
  if (first == '\\') {
    if (at + 3 >= text.size()) return std::nullopt;
    const unsigned char escaped = static_cast<unsigned char>(text[at + 2]);
    switch (escaped) {
      case 'a': value = 7; break;
      case 'b': value = 8; break;
      case 't': value = 9; break;
      case 'n': value = 10; break;
      case 'v': value = 11; break;
      case 'f': value = 12; break;
      case 'r': value = 13; break;
      case 'x':
      case '0': return std::nullopt;  // glslang: "octal and hex sequences not supported"
      default:
        if (!plain(escaped)) return std::nullopt;
        value = escaped;  // '\'' '\"' '\?' '\\', and '\C' meaning 'C', as glslang reads them
    }
    close = at + 3;
  } else {
    if (!plain(first) || first == '\'') return std::nullopt;  // '' is an error in glslang too
    value = first;
  }
  if (close >= text.size() || text[close] != '\'') return std::nullopt;
  return std::pair<int, size_t>{value, close - at + 1};
}

std::string hex_of(std::string_view bytes) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string out;
  out.reserve(bytes.size() * 2);
  for (char c : bytes) {
    out += kDigits[static_cast<unsigned char>(c) >> 4];
    out += kDigits[static_cast<unsigned char>(c) & 15];
  }
  return out;
}

int hex_digit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  return -1;
}

// What a line is, for which literals may be rewritten on it.
enum class LineKind : uint8_t {
  Code,            // everything may be rewritten
  Define,          // #define: the replacement list is code
  Condition,       // #if / #elif: values (character literals, numbers), not strings
  OtherDirective,  // #include, #line, #error, #pragma...: glslang reads these itself; left alone
};

LineKind directive_kind(std::string_view name) {
  if (name == "define") return LineKind::Define;
  if (name == "if" || name == "elif") return LineKind::Condition;
  return LineKind::OtherDirective;
}

}  // namespace

std::optional<std::string> protect_literals(std::string_view text) {
  // Most files hold none of these, and are passed through untouched.
  if (text.find('\'') == std::string_view::npos && text.find('\\') == std::string_view::npos &&
      text.find("#INF") == std::string_view::npos && text.find(kStringMarker) == std::string_view::npos)
    return std::nullopt;

  std::string out;
  size_t copied = 0;
  bool changed = false;
  auto replace = [&](size_t begin, size_t end, std::string_view with) {
    out.append(text, copied, begin - copied);
    out += with;
    copied = end;
    changed = true;
  };

  bool line_start = true;
  LineKind line = LineKind::Code;
  size_t i = 0;
  while (i < text.size()) {
    const char c = text[i];
    const char next = i + 1 < text.size() ? text[i + 1] : '\0';
    if (c == '\n') {
      line_start = true;
      line = LineKind::Code;
      ++i;
    } else if (size_t joined = after_continuation(text, i); joined != i) {
      i = joined;  // the logical line goes on
    } else if (c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v') {
      ++i;
    } else if (c == '/' && next == '/') {
      while (i < text.size() && text[i] != '\n') {
        size_t joined_comment = after_continuation(text, i);
        i = joined_comment != i ? joined_comment : i + 1;
      }
    } else if (c == '/' && next == '*') {
      // A comment is one space, even across lines: a directive goes on after it.
      const size_t end = text.find("*/", i + 2);
      i = end == std::string_view::npos ? text.size() : end + 2;
    } else if (line_start && c == '#') {
      line_start = false;
      size_t name = i + 1;
      while (name < text.size() && (text[name] == ' ' || text[name] == '\t')) ++name;
      size_t name_end = name;
      while (name_end < text.size() && is_identifier_char(text[name_end])) ++name_end;
      line = directive_kind(text.substr(name, name_end - name));
      i = name_end;
    } else if (c == '"') {
      line_start = false;
      size_t j = i + 1;
      bool escapes = false, continued = false;
      while (j < text.size() && text[j] != '"' && text[j] != '\n') {
        if (text[j] == '\\') {
          escapes = true;
          if (after_continuation(text, j) != j) continued = true;
          j += 2;
          continue;
        }
        ++j;
      }
      if (j >= text.size() || text[j] != '"') {  // unterminated: glslang reports it
        i = j;
        continue;
      }
      const std::string_view body = text.substr(i + 1, j - i - 1);
      const bool may_rewrite = line == LineKind::Code || line == LineKind::Define;
      if (may_rewrite && !continued && (escapes || body.starts_with(kStringMarker)))
        replace(i, j + 1, "\"" + std::string(kStringMarker) + hex_of(body) + "\"");
      i = j + 1;
    } else if (c == '\'') {
      line_start = false;
      auto literal = line == LineKind::OtherDirective ? std::nullopt : character_literal(text, i);
      if (!literal) {
        ++i;
        continue;
      }
      std::string value = std::to_string(literal->first);
      value.resize(literal->second, ' ');  // at most 3 digits for at least 3 characters
      replace(i, i + literal->second, value);
      i += literal->second;
    } else if (is_identifier_char(c)) {
      line_start = false;
      // glslang accepts 1.#INF only as exactly this spelling of a number.
      if (line != LineKind::OtherDirective && text.compare(i, 6, "1.#INF") == 0 && (i == 0 || text[i - 1] != '.')) {
        replace(i, i + 6, "1e999 ");
        i += 6;
        continue;
      }
      while (i < text.size() && is_identifier_char(text[i])) ++i;
    } else {
      line_start = false;
      ++i;
    }
  }
  if (!changed) return std::nullopt;
  out.append(text, copied, std::string_view::npos);
  return out;
}

std::optional<std::string> restore_literals(std::string_view preprocessed) {
  const std::string quoted_marker = "\"" + std::string(kStringMarker);
  size_t at = preprocessed.find(quoted_marker);
  if (at == std::string_view::npos) return std::nullopt;
  std::string out;
  size_t copied = 0;
  for (; at != std::string_view::npos; at = preprocessed.find(quoted_marker, at + 1)) {
    const size_t digits = at + quoted_marker.size();
    size_t end = digits;
    while (end < preprocessed.size() && hex_digit(preprocessed[end]) >= 0) ++end;
    if (end >= preprocessed.size() || preprocessed[end] != '"' || (end - digits) % 2 != 0) continue;
    std::string body;
    for (size_t d = digits; d < end; d += 2)
      body += static_cast<char>(hex_digit(preprocessed[d]) * 16 + hex_digit(preprocessed[d + 1]));
    out.append(preprocessed, copied, at - copied);
    out += "\"" + body + "\"";
    copied = end + 1;
  }
  if (copied == 0) return std::nullopt;
  out.append(preprocessed, copied, std::string_view::npos);
  return out;
}

}  // namespace kiln
