// SPDX-License-Identifier: Apache-2.0
#include "frontend/bindings.hpp"

#include <cctype>
#include <optional>

namespace kiln {
namespace {

bool word_char(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; }

class Cursor {
 public:
  explicit Cursor(std::string_view text, size_t at) : text_(text), at_(at) {}
  void skip_space() {
    while (at_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[at_]))) ++at_;
  }
  bool take(std::string_view token) {
    skip_space();
    if (text_.substr(at_, token.size()) != token) return false;
    at_ += token.size();
    return true;
  }
  std::optional<uint32_t> number() {
    skip_space();
    size_t end = at_;
    while (end < text_.size() && std::isdigit(static_cast<unsigned char>(text_[end]))) ++end;
    if (end == at_ || end - at_ > 9) return std::nullopt;
    uint32_t value = static_cast<uint32_t>(std::stoul(std::string(text_.substr(at_, end - at_))));
    at_ = end;
    return value;
  }
  // Skips to just after the `close` that balances an already consumed `open`.
  bool skip_balanced(char open, char close) {
    for (int depth = 1; at_ < text_.size(); ++at_) {
      if (text_[at_] == open) ++depth;
      if (text_[at_] == close && --depth == 0) {
        ++at_;
        return true;
      }
    }
    return false;
  }
  // The declared name: the last identifier before the declaration's ':', ';', '{' or '=', outside template
  // arguments and array sizes (`ConstantBuffer<Light> lights[4] : register(b0)` is `lights`).
  std::string declared_name() {
    std::string name;
    while (at_ < text_.size()) {
      const char c = text_[at_];
      if (c == ':' || c == ';' || c == '{' || c == '=' || c == '(') break;
      if (c == '[' && text_.substr(at_, 2) == "[[") {
        at_ += 2;
        if (!skip_balanced('[', ']') || !take("]")) break;
      } else if (c == '[' || c == '<') {
        ++at_;
        if (!skip_balanced(c, c == '[' ? ']' : '>')) break;
      } else if (word_char(c)) {
        const size_t start = at_;
        while (at_ < text_.size() && word_char(text_[at_])) ++at_;
        name = std::string(text_.substr(start, at_ - start));
      } else {
        ++at_;
      }
    }
    return name;
  }

 private:
  std::string_view text_;
  size_t at_;
};

}  // namespace

std::map<std::string, std::pair<uint32_t, uint32_t>> find_vk_bindings(std::string_view text) {
  std::map<std::string, std::pair<uint32_t, uint32_t>> found;
  for (size_t at = text.find("vk"); at != std::string_view::npos; at = text.find("vk", at + 2)) {
    if (at > 0 && word_char(text[at - 1])) continue;
    Cursor cursor(text, at + 2);
    if (!cursor.take("::") || !cursor.take("binding") || !cursor.take("(")) continue;
    auto binding = cursor.number();
    if (!binding) continue;
    uint32_t set = 0;
    if (cursor.take(",")) {
      auto s = cursor.number();
      if (!s) continue;
      set = *s;
    }
    if (!cursor.take(")") || !cursor.take("]]")) continue;
    std::string name = cursor.declared_name();
    if (!name.empty()) found[name] = {*binding, set};
  }
  return found;
}

}  // namespace kiln
