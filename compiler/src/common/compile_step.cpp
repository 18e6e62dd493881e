// SPDX-License-Identifier: Apache-2.0
#include "common/compile_step.hpp"

#include <array>
#include <utility>

namespace kiln {
namespace {

constexpr auto kNames = std::to_array<std::pair<CompileStep, std::string_view>>({
    {CompileStep::None, ""},
    {CompileStep::Preprocess, "preprocess"},
    {CompileStep::Frontend, "frontend"},
    {CompileStep::EntryPoint, "entry-point"},
    {CompileStep::Legalize, "legalize"},
    {CompileStep::CombineImageSamplers, "combine-image-samplers"},
    {CompileStep::Validate, "validate"},
    {CompileStep::Optimize, "optimize"},
    {CompileStep::ValidateOptimized, "validate-optimized"},
    {CompileStep::Instrument, "instrument"},
    {CompileStep::Reflect, "reflect"},
#define KILN_CROSS_TARGET(Enumerator, id, ...) {CompileStep::Cross##Enumerator, "cross-" #id},
#include "kiln/targets.def"
    {CompileStep::OutOfMemory, "out-of-memory"},
    {CompileStep::Internal, "internal"},
});

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

CompileStep cross_step(Target target) {
  switch (target) {
#define KILN_CROSS_TARGET(Enumerator, ...) \
  case Target::Enumerator: return CompileStep::Cross##Enumerator;
#include "kiln/targets.def"
    default: break;
  }
  return CompileStep::None;
}

}  // namespace kiln
