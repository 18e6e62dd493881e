#include "kiln/model.hpp"

#include <algorithm>

namespace kiln {

std::string_view stage_name(Stage stage) { return stage == Stage::Vertex ? "vertex" : "fragment"; }

std::optional<Stage> parse_stage(std::string_view name) {
  if (name == "vertex") return Stage::Vertex;
  if (name == "fragment") return Stage::Fragment;
  return std::nullopt;
}

std::string_view target_name(Target target) {
  switch (target) {
    case Target::Spirv: return "spirv";
    case Target::Glsl: return "glsl";
    case Target::Gles: return "gles";
    case Target::Msl: return "msl";
  }
  return "spirv";
}

std::string_view target_extension(Target target) {
  switch (target) {
    case Target::Spirv: return ".spv";
    case Target::Glsl: return ".glsl";
    case Target::Gles: return ".es.glsl";
    case Target::Msl: return ".metal";
  }
  return ".bin";
}

std::optional<Target> parse_target(std::string_view name) {
  for (Target t : {Target::Spirv, Target::Glsl, Target::Gles, Target::Msl})
    if (target_name(t) == name) return t;
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
