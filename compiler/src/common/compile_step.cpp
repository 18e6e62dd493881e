#include "common/compile_step.hpp"

#include <array>
#include <utility>

namespace kiln {
namespace {

constexpr std::array<std::pair<CompileStep, std::string_view>, 15> kNames{{
    {CompileStep::None, ""},
    {CompileStep::Preprocess, "preprocess"},
    {CompileStep::Frontend, "frontend"},
    {CompileStep::EntryPoint, "entry-point"},
    {CompileStep::Legalize, "legalize"},
    {CompileStep::CombineImageSamplers, "combine-image-samplers"},
    {CompileStep::Validate, "validate"},
    {CompileStep::Optimize, "optimize"},
    {CompileStep::ValidateOptimized, "validate-optimized"},
    {CompileStep::Reflect, "reflect"},
    {CompileStep::CrossGlsl, "cross-glsl"},
    {CompileStep::CrossGles, "cross-gles"},
    {CompileStep::CrossMsl, "cross-msl"},
    {CompileStep::OutOfMemory, "out-of-memory"},
    {CompileStep::Internal, "internal"},
}};

}  // namespace

std::string_view step_name(CompileStep step) {
  for (const auto& [s, name] : kNames)
    if (s == step) return name;
  return "?";
}

std::optional<CompileStep> parse_step(std::string_view name) {
  for (const auto& [s, n] : kNames)
    if (n == name) return s;
  return std::nullopt;
}


}  // namespace kiln
