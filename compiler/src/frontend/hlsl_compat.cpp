// SPDX-License-Identifier: Apache-2.0
#include "frontend/hlsl_compat.hpp"

#include <algorithm>
#include <cctype>
#include <vector>

namespace kiln {
namespace {

bool is_token_char(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; }

size_t skip_blanks(std::string_view text, size_t at) {
  while (at < text.size() && (text[at] == ' ' || text[at] == '\t')) ++at;
  return at;
}

// The end of the word at `at` (at itself when none starts there).
size_t word_end(std::string_view text, size_t at) {
  while (at < text.size() && is_token_char(text[at])) ++at;
  return at;
}

// Blanks, line ends and comments (the preprocessed text has none left, a caller's text may): the offset past them.
size_t skip_space(std::string_view text, size_t at) {
  while (at < text.size()) {
    if (text[at] == ' ' || text[at] == '\t' || text[at] == '\n' || text[at] == '\r') {
      ++at;
    } else if (text.substr(at, 2) == "//") {
      at = std::min(text.find('\n', at), text.size());
    } else if (text.substr(at, 2) == "/*") {
      const size_t close = text.find("*/", at + 2);
      at = close == std::string_view::npos ? text.size() : close + 2;
    } else {
      break;
    }
  }
  return at;
}

// The offset just past the `]]` that closes an attribute group whose `[[` ends before `at` (parentheses of the
// attributes' arguments balanced), or npos.
size_t attribute_group_end(std::string_view text, size_t at) {
  for (int depth = 0; at + 1 < text.size(); ++at) {
    const char c = text[at];
    if (c == '(') ++depth;
    if (c == ')' && --depth < 0) return std::string_view::npos;
    if (c == ';' || c == '{' || c == '}') return std::string_view::npos;  // no attribute spans these
    if (depth == 0 && c == ']' && text[at + 1] == ']') return at + 2;
  }
  return std::string_view::npos;
}

// Whether the word at `at` (`push_constant`, `offset`) is an attribute `vk::word` of a group (after `[[` or after a
// comma of the group's list).
bool is_vk_attribute(std::string_view text, size_t at) {
  auto previous = [&](size_t before) {  // the offset of the last non-blank character before `before`, or npos
    while (before > 0 && std::string_view(" \t\r\n").find(text[before - 1]) != std::string_view::npos) --before;
    return before == 0 ? std::string_view::npos : before - 1;
  };
  const size_t colons = previous(at);
  if (colons == std::string_view::npos || colons == 0 || text[colons] != ':' || text[colons - 1] != ':') return false;
  const size_t vk_end = previous(colons - 1);
  if (vk_end == std::string_view::npos || vk_end < 1 || text.substr(vk_end - 1, 2) != "vk" ||
      (vk_end >= 2 && is_token_char(text[vk_end - 2])))
    return false;
  const size_t opener = previous(vk_end - 1);
  return opener != std::string_view::npos && (text[opener] == ',' || (text[opener] == '[' && opener > 0 && text[opener - 1] == '['));
}

}  // namespace

std::optional<std::string> rewrite_push_constants(std::string_view text) {
  std::optional<std::string> out;
  size_t copied = 0;
  constexpr std::string_view kWord = "push_constant";
  for (size_t at = text.find(kWord); at != std::string_view::npos; at = text.find(kWord, at + 1)) {
    // The whole word only: a variable named `push_constants` is no attribute (it was taken for one, and the
    // declaration rewritten twice).
    if ((at > 0 && is_token_char(text[at - 1])) || word_end(text, at) != at + kWord.size()) continue;
    if (at < copied || !is_vk_attribute(text, at)) continue;
    size_t end = attribute_group_end(text, at + kWord.size());
    if (end == std::string_view::npos) continue;
    // Other attribute groups may follow (`[[vk::push_constant]] [[vk::binding(1)]]`), on this line or the next.
    for (size_t next = skip_space(text, end); text.substr(next, 2) == "[["; next = skip_space(text, end)) {
      end = attribute_group_end(text, next + 2);
      if (end == std::string_view::npos) break;
    }
    if (end == std::string_view::npos) continue;
    // `T name ;` (or `T name :` / `T name [`) with T a plain type name, not ConstantBuffer<...>, cbuffer or a keyword
    // that glslang already reads as DXC does.
    const size_t type_at = skip_space(text, end), type_end = word_end(text, type_at);
    if (type_end == type_at) continue;
    const std::string_view type = text.substr(type_at, type_end - type_at);
    if (type == "struct") {
      // `[[vk::push_constant]] struct [T] { ... } name;` (glslang 12: $Global too) becomes
      // `[[vk::push_constant]] struct T { ... }; [[vk::push_constant]] ConstantBuffer<T> name;` on the same lines,
      // an unnamed struct named after its variable.
      const size_t tag_at = skip_space(text, type_end), tag_end = word_end(text, tag_at);
      const size_t open = skip_space(text, tag_end);
      if (open >= text.size() || text[open] != '{') continue;
      size_t close = open;
      for (int depth = 0; close < text.size(); ++close) {
        depth += text[close] == '{' ? 1 : text[close] == '}' ? -1 : 0;
        if (depth == 0) break;
      }
      if (close >= text.size()) continue;
      const size_t name_at = skip_space(text, close + 1), name_end = word_end(text, name_at);
      if (name_end == name_at) continue;
      const size_t after = skip_space(text, name_end);
      if (after >= text.size() || (text[after] != ';' && text[after] != ':' && text[after] != '[')) continue;
      const std::string tag = tag_end != tag_at ? std::string(text.substr(tag_at, tag_end - tag_at))
                                                : "kiln_push_constant_" + std::string(text.substr(name_at, name_end - name_at));
      if (!out) out.emplace();
      out->append(text.substr(copied, type_end - copied));
      if (tag_end == tag_at) out->append(" ").append(tag);
      out->append(text.substr(type_end, close + 1 - type_end));
      out->append("; [[vk::push_constant]] ConstantBuffer<").append(tag).append(">");
      copied = close + 1;
      continue;
    }
    if (type == "ConstantBuffer" || type == "cbuffer" || type == "const" || type == "static" || type == "uniform")
      continue;
    const size_t name_at = skip_space(text, type_end), name_end = word_end(text, name_at);
    if (name_end == name_at) continue;
    const size_t after = skip_space(text, name_end);
    if (after >= text.size() || (text[after] != ';' && text[after] != ':' && text[after] != '[')) continue;
    if (!out) out.emplace();
    out->append(text.substr(copied, type_at - copied));
    out->append("ConstantBuffer<").append(type).append(">");
    copied = type_end;
  }
  if (out) out->append(text.substr(copied));
  return out;
}

std::optional<std::string> rewrite_attribute_lists(std::string_view text) {
  std::optional<std::string> out;
  size_t copied = 0;
  for (size_t open = text.find("[["); open != std::string_view::npos; open = text.find("[[", open + 2)) {
    if (open < copied) continue;
    const size_t end = attribute_group_end(text, open + 2);
    if (end == std::string_view::npos) continue;
    // The commas between the group's attributes (not those of an attribute's arguments).
    std::vector<size_t> commas;
    int depth = 0;
    for (size_t at = open + 2; at + 2 < end; ++at) {
      depth += text[at] == '(' ? 1 : text[at] == ')' ? -1 : 0;
      if (depth == 0 && text[at] == ',') commas.push_back(at);
    }
    if (commas.empty()) continue;
    if (!out) out.emplace();
    for (size_t comma : commas) {
      out->append(text.substr(copied, comma - copied)).append("]][[");
      copied = comma + 1;
    }
    open = end - 2;
  }
  if (out) out->append(text.substr(copied));
  return out;
}

namespace {

// The arguments of the call whose '(' is at `open`: each one's text, split at depth-0 commas; `close` gets the
// offset of the matching ')'. Nothing when the parentheses do not balance (an unfinished call, a string).
std::optional<std::vector<std::string_view>> call_arguments(std::string_view text, size_t open, size_t& close) {
  std::vector<std::string_view> arguments;
  int depth = 0;
  size_t start = open + 1;
  // Bounded: a call is far shorter, and unfinished calls by the thousand must not make each scan the rest of the text.
  for (size_t at = open; at < text.size() && at - open < 4096; ++at) {
    const char c = text[at];
    if (c == '"' || c == ';' || c == '{' || c == '}') return std::nullopt;  // no call spans these
    if (c == '(' || c == '[') ++depth;
    if (c == ')' || c == ']') --depth;
    if (depth == 1 && c == ',') {
      arguments.push_back(text.substr(start, at - start));
      start = at + 1;
    }
    if (depth == 0) {
      if (c != ')') return std::nullopt;
      arguments.push_back(text.substr(start, at - start));
      close = at;
      return arguments;
    }
  }
  return std::nullopt;
}

// Whether `text` declares a function or variable named `name` (a type word, then the name): its own, kept.
bool declares(std::string_view text, std::string_view name) {
  for (size_t at = text.find(name); at != std::string_view::npos; at = text.find(name, at + 1)) {
    if ((at > 0 && is_token_char(text[at - 1])) || is_token_char(text[std::min(text.size() - 1, at + name.size())])) continue;
    size_t before = at;
    while (before > 0 && (text[before - 1] == ' ' || text[before - 1] == '\t' || text[before - 1] == '\n')) --before;
    if (before == at || before == 0 || !is_token_char(text[before - 1])) continue;
    size_t word = before;
    while (word > 0 && is_token_char(text[word - 1])) --word;
    const std::string_view previous = text.substr(word, before - word);
    if (previous != "return" && previous != "else" && previous != "case") return true;
  }
  return false;
}

}  // namespace

std::optional<std::string> rewrite_hlsl2021_intrinsics(std::string_view text) {
  struct Intrinsic {
    std::string_view name;
    size_t arguments;
    std::string_view open, separator1, separator2, close;
  };
  static constexpr Intrinsic kIntrinsics[] = {
      {"select", 3, "((", ") ? (", ") : (", "))"},
      {"and", 2, "((", ") && (", "", "))"},
      {"or", 2, "((", ") || (", "", "))"},
  };
  std::optional<std::string> out;
  std::string current(text);
  for (const Intrinsic& intrinsic : kIntrinsics) {
    if (current.find(intrinsic.name) == std::string::npos || declares(current, intrinsic.name)) continue;
    // Innermost calls first (a call in an argument is rewritten before the call around it): repeat until none is
    // left, each pass rewriting the calls whose arguments hold no other call of this name.
    for (int pass = 0; pass < 64; ++pass) {
      std::string next;
      size_t copied = 0;
      bool changed = false;
      const std::string_view view(current);
      for (size_t at = view.find(intrinsic.name); at != std::string_view::npos; at = view.find(intrinsic.name, at + 1)) {
        if (at < copied) continue;
        if ((at > 0 && (is_token_char(view[at - 1]) || view[at - 1] == '.'))) continue;
        const size_t open = skip_blanks(view, at + intrinsic.name.size());
        if (word_end(view, at) != at + intrinsic.name.size() || open >= view.size() || view[open] != '(') continue;
        size_t close = 0;
        auto arguments = call_arguments(view, open, close);
        if (!arguments || arguments->size() != intrinsic.arguments) continue;
        bool nested = false;
        for (std::string_view argument : *arguments)
          for (size_t inner = argument.find(intrinsic.name); inner != std::string_view::npos; inner = argument.find(intrinsic.name, inner + 1))
            nested = nested || ((inner == 0 || !is_token_char(argument[inner - 1])) &&
                                word_end(argument, inner) == inner + intrinsic.name.size());
        if (nested) continue;
        next.append(view.substr(copied, at - copied));
        next.append(intrinsic.open).append((*arguments)[0]).append(intrinsic.separator1).append((*arguments)[1]);
        if (intrinsic.arguments == 3) next.append(intrinsic.separator2).append((*arguments)[2]);
        next.append(intrinsic.close);
        copied = close + 1;
        changed = true;
      }
      if (!changed) break;
      next.append(view.substr(copied));
      current = std::move(next);
      out = current;
    }
  }
  return out;
}

namespace {

bool is_swizzle(std::string_view word) {
  if (word.empty() || word.size() > 4) return false;
  const std::string_view set = std::string_view("xyzw").find(word[0]) != std::string_view::npos ? "xyzw" : "rgba";
  for (char c : word)
    if (set.find(c) == std::string_view::npos) return false;
  return true;
}

size_t skip_spaces(std::string_view text, size_t at) {
  while (at < text.size() && (text[at] == ' ' || text[at] == '\t')) ++at;
  return at;
}

}  // namespace

std::optional<std::string> rewrite_literal_swizzles(std::string_view text) {
  std::optional<std::string> out;
  size_t copied = 0;
  bool directive = false;  // on a preprocessor line (#line 12 "x"): left alone
  size_t line_start = 0;
  for (size_t at = 0; at < text.size(); ++at) {
    const char c = text[at];
    if (c == '\n') {
      directive = false;
      line_start = at + 1;
      continue;
    }
    if (c == '#' && skip_spaces(text, line_start) == at) directive = true;
    if (directive || !std::isdigit(static_cast<unsigned char>(c)) || (at > 0 && (is_token_char(text[at - 1]) || text[at - 1] == '.')))
      continue;
    // The number: digits, a fraction, an exponent, a suffix.
    size_t end = at;
    while (end < text.size() && std::isdigit(static_cast<unsigned char>(text[end]))) ++end;
    bool ends_in_dot = false;
    if (end < text.size() && text[end] == '.') {
      ++end;
      const size_t digits = end;
      while (end < text.size() && std::isdigit(static_cast<unsigned char>(text[end]))) ++end;
      ends_in_dot = end == digits;
    }
    if (!ends_in_dot && end < text.size() && (text[end] == 'e' || text[end] == 'E')) {
      size_t exponent = end + 1;
      if (exponent < text.size() && (text[exponent] == '+' || text[exponent] == '-')) ++exponent;
      if (exponent < text.size() && std::isdigit(static_cast<unsigned char>(text[exponent]))) {
        end = exponent;
        while (end < text.size() && std::isdigit(static_cast<unsigned char>(text[end]))) ++end;
      }
    }
    if (!ends_in_dot && end < text.size() && std::string_view("fFhHlLuU").find(text[end]) != std::string_view::npos) ++end;
    // Then `. swizzle` (or, after "0.", only blanks and the swizzle: the preprocessor took the dot into the number).
    size_t word = skip_spaces(text, end);
    if (!ends_in_dot) {
      if (word >= text.size() || text[word] != '.') {
        at = end - 1;
        continue;
      }
      word = skip_spaces(text, word + 1);
    } else if (word == end) {
      at = end - 1;
      continue;  // "0.x..." with no blank is one token the preprocessor kept: glslang reads it as it reads DXC's
    }
    const size_t word_finish = word_end(text, word);
    if (!is_swizzle(text.substr(word, word_finish - word))) {
      at = end - 1;
      continue;
    }
    const std::string_view number = text.substr(at, (ends_in_dot ? end - 1 : end) - at);
    if (!out) out.emplace();
    out->append(text.substr(copied, at - copied)).append("(").append(number).append(").").append(text.substr(word, word_finish - word));
    copied = word_finish;
    at = word_finish - 1;
  }
  if (out) out->append(text.substr(copied));
  return out;
}

namespace {

std::string_view trimmed(std::string_view text) {
  while (!text.empty() && std::isspace(static_cast<unsigned char>(text.front()))) text.remove_prefix(1);
  while (!text.empty() && std::isspace(static_cast<unsigned char>(text.back()))) text.remove_suffix(1);
  return text;
}

std::string newlines_in(std::string_view text) { return std::string(std::count(text.begin(), text.end(), '\n'), '\n'); }

// `expression` with each whole word in `names` qualified as `scope::word` (an enumerator's initializer naming an
// earlier one: glslang looks names up only qualified inside a namespace).
std::string qualified(std::string_view expression, const std::vector<std::string>& names, std::string_view scope) {
  std::string out;
  for (size_t at = 0; at < expression.size();) {
    const size_t end = word_end(expression, at);
    if (end == at) {
      out += expression[at++];
      continue;
    }
    const std::string_view word = expression.substr(at, end - at);
    const bool after_scope = at >= 2 && expression.substr(at - 2, 2) == "::";
    const bool after_member = at >= 1 && expression[at - 1] == '.';
    if (!scope.empty() && !after_scope && !after_member && std::find(names.begin(), names.end(), word) != names.end())
      out.append(scope).append("::");
    out.append(word);
    at = end;
  }
  return out;
}

}  // namespace

std::optional<std::string> rewrite_enums(std::string_view text) {
  std::optional<std::string> out;
  size_t copied = 0;
  constexpr std::string_view kWord = "enum";
  for (size_t at = text.find(kWord); at != std::string_view::npos; at = text.find(kWord, at + 1)) {
    if (at < copied || (at > 0 && (is_token_char(text[at - 1]) || text[at - 1] == '.')) ||
        word_end(text, at) != at + kWord.size())
      continue;
    // enum [class|struct] [Name] [: T] { ... } ;
    size_t cursor = skip_space(text, at + kWord.size());
    bool scoped = false;
    for (std::string_view key : {"class", "struct"})
      if (text.substr(cursor, key.size()) == key && word_end(text, cursor) == cursor + key.size()) {
        scoped = true;
        cursor = skip_space(text, cursor + key.size());
      }
    const size_t name_end = word_end(text, cursor);
    const std::string name(text.substr(cursor, name_end - cursor));
    if (scoped && name.empty()) continue;
    cursor = skip_space(text, name_end);
    std::string type = "int";
    if (cursor < text.size() && text[cursor] == ':' && text.substr(cursor, 2) != "::") {
      const size_t type_start = skip_space(text, cursor + 1);
      size_t type_finish = type_start;
      while (type_finish < text.size() && (is_token_char(text[type_finish]) || text[type_finish] == ' ')) ++type_finish;
      type = std::string(trimmed(text.substr(type_start, type_finish - type_start)));
      if (type.empty()) continue;
      cursor = skip_space(text, type_finish);
    }
    if (cursor >= text.size() || text[cursor] != '{') continue;
    const size_t open = cursor, close = text.find('}', open);
    if (close == std::string_view::npos) break;  // no later enum closes either: one scan, not one per `enum`
    if (text.substr(open + 1, close - open - 1).find('{') != std::string_view::npos) continue;
    const size_t semicolon = skip_space(text, close + 1);
    if (semicolon >= text.size() || text[semicolon] != ';') continue;  // `enum E { ... } e;`: glslang's error stays
    // The enumerators: split at the commas outside parentheses.
    std::vector<std::string_view> items;
    int depth = 0;
    size_t start = open + 1;
    for (size_t i = open + 1; i <= close; ++i) {
      const char c = text[i];
      depth += c == '(' ? 1 : c == ')' ? -1 : 0;
      if ((depth == 0 && c == ',') || i == close) {
        items.push_back(text.substr(start, i - start));
        start = i + 1;
      }
    }
    std::string rewritten = newlines_in(text.substr(at, open - at));
    if (!name.empty()) rewritten += "typedef " + type + " " + name + "; namespace " + name + " {";
    std::vector<std::string> names;
    bool valid = true;
    for (std::string_view item : items) {
      const std::string_view body = trimmed(item);
      if (body.empty()) {
        rewritten += newlines_in(item);
        continue;
      }
      const size_t item_name_end = word_end(body, 0);
      const std::string enumerator(body.substr(0, item_name_end));
      const std::string_view rest = trimmed(body.substr(item_name_end));
      if (enumerator.empty() || std::isdigit(static_cast<unsigned char>(enumerator[0])) || (!rest.empty() && rest[0] != '=')) {
        valid = false;
        break;
      }
      std::string value;
      if (!rest.empty())
        value = qualified(trimmed(rest.substr(1)), names, name);
      else if (names.empty())
        value = "0";
      else
        value = (name.empty() ? "" : name + "::") + names.back() + " + 1";
      const size_t leading = item.find(body);
      rewritten += newlines_in(item.substr(0, leading));
      rewritten += " static const " + type + " " + enumerator + " = (" + type + ")(" + value + ");";
      rewritten += newlines_in(item.substr(leading));
      names.push_back(enumerator);
    }
    if (!valid || names.empty()) continue;
    if (!name.empty()) rewritten += " }";
    if (!scoped && !name.empty())
      for (const std::string& enumerator : names)
        rewritten += " static const " + type + " " + enumerator + " = " + name + "::" + enumerator + ";";
    rewritten += newlines_in(text.substr(close, semicolon - close));
    if (!out) out.emplace();
    out->append(text.substr(copied, at - copied)).append(rewritten);
    copied = semicolon + 1;
    at = semicolon;
  }
  if (out) out->append(text.substr(copied));
  return out;
}

std::optional<std::string> rewrite_byte_address_atomics(std::string_view text) {
  // The methods and the positions of their value arguments (DXC's RWByteAddressBuffer, all uint).
  struct Method {
    std::string_view name;
    size_t first_value, last_value;
  };
  static constexpr Method kMethods[] = {
      {"InterlockedAdd", 1, 1},      {"InterlockedAnd", 1, 1}, {"InterlockedOr", 1, 1},
      {"InterlockedXor", 1, 1},      {"InterlockedMin", 1, 1}, {"InterlockedMax", 1, 1},
      {"InterlockedExchange", 1, 1}, {"InterlockedCompareExchange", 1, 2}, {"InterlockedCompareStore", 1, 2},
  };
  std::optional<std::string> out;
  size_t copied = 0;
  // The preprocessed text spaces its tokens (`raw . InterlockedAdd ( 0 , 1 )`): blanks may stand around the dot.
  for (size_t name_at = text.find("Interlocked"); name_at != std::string_view::npos; name_at = text.find("Interlocked", name_at + 1)) {
    if (name_at < copied || (name_at > 0 && is_token_char(text[name_at - 1]))) continue;
    size_t dot = name_at;
    while (dot > 0 && (text[dot - 1] == ' ' || text[dot - 1] == '\t')) --dot;
    if (dot == 0 || text[dot - 1] != '.') continue;
    const size_t name_end = word_end(text, name_at);
    const std::string_view called = text.substr(name_at, name_end - name_at);
    const Method* method = nullptr;
    for (const Method& row : kMethods)
      if (row.name == called) method = &row;
    const size_t open = skip_space(text, name_end);
    if (!method || open >= text.size() || text[open] != '(') continue;
    size_t close = 0;
    auto arguments = call_arguments(text, open, close);
    if (!arguments || arguments->size() <= method->last_value) continue;
    std::string call = "(";
    for (size_t i = 0; i < arguments->size(); ++i) {
      const std::string_view argument = (*arguments)[i];
      if (i > 0) call += ",";
      const bool value = i >= method->first_value && i <= method->last_value && !trimmed(argument).starts_with("(uint)(");
      call += value ? "(uint)(" + std::string(argument) + ")" : std::string(argument);
    }
    call += ")";
    if (!out) out.emplace();
    out->append(text.substr(copied, open - copied)).append(call);
    copied = close + 1;
  }
  if (out) out->append(text.substr(copied));
  return out;
}

namespace {

// The data members of the struct whose body opens at `open` ('{'): the last word of each declaration before its
// semantic, array size, initializer or end, past attribute groups; methods and nested bodies are left out.
std::vector<std::string> record_members(std::string_view text, size_t open) {
  std::vector<std::string> members;
  std::string last;
  bool method = false;
  int depth = 0;
  for (size_t at = open + 1; at < text.size() && at < open + 65536; ++at) {
    const char c = text[at];
    if (text.substr(at, 2) == "[[") {
      const size_t end = attribute_group_end(text, at + 2);
      if (end == std::string_view::npos) break;
      at = end - 1;
      continue;
    }
    if (c == '{') ++depth;
    if (c == '}' && depth-- == 0) break;
    if (depth > 0) continue;
    if (c == '(') method = true;
    if (c == ';') {
      if (!method && !last.empty()) members.push_back(last);
      last.clear();
      method = false;
    }
    if (c == ':' || c == '[' || c == '=' || c == ',') {
      if (c == ',' && !method && !last.empty()) members.push_back(last);  // `float a, b;`
      if (c != ',') {
        while (at < text.size() && text[at] != ';' && text[at] != ',') ++at;
        --at;
      }
      if (c == ',') last.clear();
      continue;
    }
    if (is_token_char(c) && !is_token_char(text[at - 1])) {
      last = std::string(text.substr(at, word_end(text, at) - at));
      at = word_end(text, at) - 1;
    }
  }
  return members;
}

}  // namespace

std::optional<MemberOffsets> strip_member_offsets(std::string_view text) {
  std::optional<MemberOffsets> out;
  constexpr std::string_view kWord = "offset";
  for (size_t at = text.find(kWord); at != std::string_view::npos; at = text.find(kWord, at + 1)) {
    if ((at > 0 && is_token_char(text[at - 1])) || word_end(text, at) != at + kWord.size() || !is_vk_attribute(text, at)) continue;
    const size_t open = text.rfind("[[", at), end = attribute_group_end(text, at + kWord.size());
    if (open == std::string_view::npos || end == std::string_view::npos) continue;
    // `( N )`
    size_t cursor = skip_space(text, at + kWord.size());
    if (cursor >= text.size() || text[cursor] != '(') continue;
    const size_t digits = skip_space(text, cursor + 1), digits_end = word_end(text, digits);
    if (digits_end == digits || digits_end - digits > 9 ||
        !std::all_of(text.begin() + digits, text.begin() + digits_end, [](char c) { return std::isdigit(static_cast<unsigned char>(c)); }))
      continue;
    cursor = skip_space(text, digits_end);
    if (cursor >= text.size() || text[cursor] != ')' || skip_space(text, cursor + 1) + 2 != end) continue;
    // The member: the last word before its end, its semantic, its array size or the next declarator.
    std::string member;
    for (size_t scan = end; scan < text.size() && scan < end + 4096; ++scan) {
      const char c = text[scan];
      if (c == ';' || c == ':' || c == '[' || c == ',' || c == '{' || c == '}' || c == '(') break;
      if (c == '<') {  // template arguments (`vector<float, 4>`): not the name
        const size_t close = text.find('>', scan);
        if (close == std::string_view::npos) break;
        scan = close;
        continue;
      }
      if (is_token_char(c) && !is_token_char(text[scan - 1]) && !std::isdigit(static_cast<unsigned char>(c))) {
        member = std::string(text.substr(scan, word_end(text, scan) - scan));
        scan = word_end(text, scan) - 1;
      }
    }
    // The record: the struct or cbuffer whose brace encloses the attribute.
    // Bounded (a record is far shorter): text of many attributes outside any brace stays linear.
    size_t brace = open;
    for (int depth = 0; brace > 0 && open - brace < 8192; --brace) {
      const char c = text[brace - 1];
      if (c == '}') ++depth;
      if (c == '{' && depth-- == 0) break;
    }
    if (member.empty() || brace == 0 || text[brace - 1] != '{') continue;
    const size_t head_start = text.find_last_of(";{}", brace - 2) == std::string_view::npos ? 0 : text.find_last_of(";{}", brace - 2) + 1;
    std::string record;
    const std::string_view head = text.substr(head_start, brace - 1 - head_start);
    for (std::string_view key : {"struct", "cbuffer", "tbuffer"}) {
      for (size_t k = head.find(key); k != std::string_view::npos && record.empty(); k = head.find(key, k + 1)) {
        if ((k > 0 && is_token_char(head[k - 1])) || word_end(head, k) != k + key.size()) continue;
        const size_t name_at = skip_space(head, k + key.size());
        record = std::string(head.substr(name_at, word_end(head, name_at) - name_at));
      }
    }
    if (record.empty()) continue;
    if (!out) out.emplace(MemberOffsets{std::string(text), {}});
    std::fill(out->text.begin() + static_cast<long>(open), out->text.begin() + static_cast<long>(end), ' ');
    out->stated.push_back({record, record_members(text, brace - 1), member, static_cast<uint32_t>(std::stoul(std::string(text.substr(digits, digits_end - digits)))), at});
  }
  return out;
}

std::optional<std::string> rewrite_reserved_names(std::string_view text) {
  // The words glslang 12 refuses as names that DXC takes (glslangValidator on `Texture2D <word>;`); `line`, `point`
  // and `triangle` are refused too, but they are also geometry-shader qualifiers a rename would break.
  static constexpr std::string_view kWords[] = {"texture", "sampler", "sampler1D", "sampler2D", "sampler3D", "samplerCUBE", "sampler_state"};
  auto declared = [&](std::string_view word) {  // `T word` followed by what ends a declarator
    for (size_t at = text.find(word); at != std::string_view::npos; at = text.find(word, at + 1)) {
      if ((at > 0 && is_token_char(text[at - 1])) || word_end(text, at) != at + word.size()) continue;
      size_t before = at;
      while (before > 0 && (text[before - 1] == ' ' || text[before - 1] == '\t')) --before;
      if (before == at || before == 0 || (!is_token_char(text[before - 1]) && text[before - 1] != '>')) continue;
      const size_t after = skip_space(text, at + word.size());
      if (after < text.size() && std::string_view(":;[,)=").find(text[after]) != std::string_view::npos) return true;
    }
    return false;
  };
  std::vector<std::string_view> renamed;
  for (std::string_view word : kWords)
    if (declared(word)) renamed.push_back(word);
  if (renamed.empty()) return std::nullopt;
  std::string out;
  out.reserve(text.size() + 64);
  size_t line_start = 0;
  bool directive = false;  // `#line 3 "texture.hlsl"`: left alone
  for (size_t at = 0; at < text.size();) {
    const char c = text[at];
    if (c == '\n') {
      line_start = at + 1;
      directive = false;
    }
    if (c == '#' && skip_blanks(text, line_start) == at) directive = true;
    const size_t end = is_token_char(c) && (at == 0 || !is_token_char(text[at - 1])) ? word_end(text, at) : at;
    if (end == at) {
      out += c;
      ++at;
      continue;
    }
    const std::string_view word = text.substr(at, end - at);
    if (!directive && std::find(renamed.begin(), renamed.end(), word) != renamed.end()) out.append(kReservedNamePrefix);
    out.append(word);
    at = end;
  }
  return out;
}

std::optional<std::string> rewrite_compare_store(std::string_view text) {
  constexpr std::string_view kName = "InterlockedCompareStore";
  std::optional<std::string> out;
  size_t copied = 0;
  for (size_t at = text.find(kName); at != std::string_view::npos; at = text.find(kName, at + 1)) {
    if (at < copied || (at > 0 && is_token_char(text[at - 1])) || word_end(text, at) != at + kName.size()) continue;
    const size_t open = skip_space(text, at + kName.size());
    size_t close = 0;
    if (open >= text.size() || text[open] != '(') continue;
    const auto arguments = call_arguments(text, open, close);
    if (!arguments || (arguments->size() != 3)) continue;
    if (!out) out.emplace();
    out->append(text.substr(copied, at - copied)).append("InterlockedCompareExchange");
    out->append(text.substr(at + kName.size(), close - at - kName.size())).append(", kiln_compare_store_original)");
    copied = close + 1;
  }
  if (out) out->append(text.substr(copied));
  return out;
}

std::vector<std::smatch> file_scope_matches(const std::string& text, const std::regex& declaration) {
  std::vector<std::smatch> out;
  size_t scanned = 0;
  long depth = 0;
  for (auto it = std::sregex_iterator(text.begin(), text.end(), declaration); it != std::sregex_iterator(); ++it) {
    const size_t at = static_cast<size_t>(it->position(0));
    for (; scanned < at; ++scanned) depth += text[scanned] == '{' ? 1 : text[scanned] == '}' ? -1 : 0;
    if (depth == 0) out.push_back(*it);
  }
  return out;
}

std::optional<std::string> interface_attribute_error(std::string_view warning, bool combined_image_samplers) {
  struct Row {
    std::string_view attribute, dxc, instead;
  };
  static constexpr Row kRows[] = {
      {"offset", "sets a block member's byte offset",
       "order and pad the members so that HLSL's packing gives the offsets (or use packoffset in a cbuffer)"},
      {"image_format", "sets a storage image's format, which Vulkan requires to match the view's",
       "glslang infers the format from the texel type: use a texel type that implies it"},
      {"combinedImageSampler", "pairs a texture and a sampler into one combined image sampler",
       "set \"bindings\": {\"combined_image_samplers\": true} (or --combined-image-samplers), which pairs a texture and a "
       "sampler that share a register number"},
      {"counter_binding", "places a UAV's counter buffer at that binding", "drop the counter (an explicit RWByteAddressBuffer)"},
      {"shader_record_ext", "places a buffer in the ray tracing shader record", "compile ray tracing shaders with DXC"},
      {"ext_decorate", "adds a SPIR-V decoration", "compile this shader with DXC"},
      {"ext_decorate_id", "adds a SPIR-V decoration", "compile this shader with DXC"},
      {"ext_decorate_string", "adds a SPIR-V decoration", "compile this shader with DXC"},
      {"ext_storage_class", "sets a variable's SPIR-V storage class", "compile this shader with DXC"},
  };
  constexpr std::string_view kSuffix = "' : unrecognized attribute";
  if (!warning.starts_with('\'') || !warning.ends_with(kSuffix)) return std::nullopt;
  const std::string_view name = warning.substr(1, warning.size() - 1 - kSuffix.size());
  // With combined image samplers already on, what pairs them is a shared binding, not the setting.
  constexpr std::string_view kPairedByBinding =
      "combined image samplers are on, and they pair a texture and a sampler that share a binding: drop the attribute "
      "and give the texture and its sampler one register number (tN and sN) or the same [[vk::binding(N)]]";
  for (Row row : kRows)
    if (name == row.attribute) {
      if (name == "combinedImageSampler" && combined_image_samplers) row.instead = kPairedByBinding;
      // Quoting the word first, as glslang does, lets the driver find its column.
      return "'" + std::string(name) + "' : [[vk::" + std::string(name) + "]] changes the interface in DXC (it " +
             std::string(row.dxc) + "); glslang 12 ignores it, so the shader would be built with another interface: " +
             std::string(row.instead);
    }
  return std::nullopt;
}

}  // namespace kiln
