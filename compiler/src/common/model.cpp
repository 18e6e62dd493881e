// SPDX-License-Identifier: Apache-2.0
#include "kiln/model.hpp"

#include <algorithm>
#include <cctype>

#include "kiln/pack_format.hpp"

namespace kiln {

char register_class_letter(RegisterClass register_class) { return "btsu"[static_cast<size_t>(register_class)]; }

std::optional<RegisterClass> parse_register_class(std::string_view letter) {
  for (RegisterClass c : {RegisterClass::B, RegisterClass::T, RegisterClass::S, RegisterClass::U})
    if (letter.size() == 1 && letter[0] == register_class_letter(c)) return c;
  return std::nullopt;
}

void BindingOptions::override_with(const BindingOptions& later) {
  for (const auto& [where, value] : later.shifts) shifts[where] = value;
  if (later.auto_bind) auto_bind = later.auto_bind;
  if (later.combined_image_samplers) combined_image_samplers = later.combined_image_samplers;
  if (later.global_uniform) global_uniform = later.global_uniform;
}

uint32_t BindingOptions::shift(RegisterClass register_class, uint32_t space) const {
  if (auto it = shifts.find({register_class, int64_t{space}}); it != shifts.end()) return it->second;
  if (auto it = shifts.find({register_class, kAllSpaces}); it != shifts.end()) return it->second;
  return 0;
}

std::string BindingOptions::canonical() const {
  std::string out;
  for (const auto& [where, value] : shifts) {
    if (value == 0 && where.second == kAllSpaces) continue;  // the default, spelled out
    out += std::string("-fvk-") + register_class_letter(where.first) + "-shift " + std::to_string(value) + " " +
           (where.second == kAllSpaces ? std::string("all") : std::to_string(where.second)) + " ";
  }
  if (!auto_binds()) out += "-no-auto-bind ";
  if (combines()) out += "-combined-image-samplers ";
  if (global_uniform)
    out += "-fvk-bind-globals " + std::to_string(global_uniform->first) + " " + std::to_string(global_uniform->second) + " ";
  if (!out.empty()) out.pop_back();
  return out;
}

bool is_identifier(std::string_view text) {
  if (text.empty() || std::isdigit(static_cast<unsigned char>(text[0]))) return false;
  return std::all_of(text.begin(), text.end(), [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; });
}

std::optional<Define> parse_define(std::string_view text) {
  const size_t equals = text.find('=');
  Define define;
  define.name = std::string(text.substr(0, equals));
  if (equals != std::string_view::npos) define.value = std::string(text.substr(equals + 1));
  if (!define_problem(define).empty()) return std::nullopt;
  return define;
}

std::string define_problem(const Define& define) {
  if (!is_identifier(define.name))
    return "'" + echoed(define.name) + "' is not a preprocessor identifier: letters, digits and '_', not starting with a digit";
  // glslang's preprocessor reads names and numbers of up to 1023 characters (its MaxTokenLength, 1024); a longer one
  // was its bare "name too long", which names neither the define nor the value.
  constexpr size_t kMaxTokenCharacters = 1023;
  if (define.name.size() > kMaxTokenCharacters)
    return "'" + echoed(define.name) + "' is longer than the " + std::to_string(kMaxTokenCharacters) +
           " characters a preprocessor name may have";
  size_t run = 0;
  for (char c : define.value) {
    run = std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '.' ? run + 1 : 0;
    if (run > kMaxTokenCharacters)
      return "the value of '" + echoed(define.name) + "' holds a name or number longer than the " +
             std::to_string(kMaxTokenCharacters) + " characters the preprocessor reads";
  }
  // A value is one line of the preamble: a newline would end the #define and start another directive.
  for (unsigned char c : define.value)
    if (c < 0x20 && c != '\t')
      return "the value of '" + echoed(define.name) + "' holds a line break or another control character";
  if (define.value.ends_with('\\'))
    return "the value of '" + echoed(define.name) +
           "' ends in a backslash, which would continue the #define onto the next line and swallow it";
  return "";
}

std::string_view optimizer_recipe_name(OptimizerRecipe recipe) { return recipe == OptimizerRecipe::Kiln ? "kiln" : "O"; }

std::optional<OptimizerRecipe> parse_optimizer_recipe(std::string_view name) {
  for (OptimizerRecipe recipe : {OptimizerRecipe::Kiln, OptimizerRecipe::Stock})
    if (optimizer_recipe_name(recipe) == name) return recipe;
  return std::nullopt;
}

bool KeywordGroup::has_none() const { return index_of("") >= 0; }

int KeywordGroup::index_of(std::string_view keyword) const {
  for (size_t i = 0; i < values.size(); ++i)
    if (values[i] == keyword) return static_cast<int>(i);
  return -1;
}

std::vector<std::string> enabled_keywords(const std::vector<KeywordGroup>& groups, const Variant& variant,
                                          std::optional<Stage> stage) {
  std::vector<std::string> keywords;
  for (size_t g = 0; g < groups.size() && g < variant.choice.size(); ++g) {
    if (stage && !(groups[g].stages & stage_bit(*stage))) continue;
    const std::string& value = groups[g].values[variant.choice[g]];
    if (!value.empty()) keywords.push_back(value);
  }
  std::sort(keywords.begin(), keywords.end());
  return keywords;
}

std::string join_keywords(const std::vector<std::string>& keywords) {
  if (keywords.empty()) return "<none>";
  std::string out;
  for (const std::string& k : keywords) {
    if (!out.empty()) out += ' ';
    out += k;
  }
  return out;
}

}  // namespace kiln
