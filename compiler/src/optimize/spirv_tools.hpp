// SPDX-License-Identifier: Apache-2.0
// Stage 5 (after the front end): legalize HLSL-derived SPIR-V, validate, optimize, validate again.
#pragma once

#include <cstdint>
#include <functional>
#include <string>

#include "common/compile_step.hpp"
#include "common/target_environment.hpp"
#include "kiln/model.hpp"
#include "kiln/result.hpp"

#include <spirv-tools/libspirv.h>
#include <vector>

namespace kiln {

// SPIRV-Tools' name for kTargetEnvironment.
constexpr spv_target_env spirv_tools_environment() {
  static_assert(kTargetEnvironment.vulkan_major == 1 && kTargetEnvironment.vulkan_minor == 1,
                "map the new Vulkan version to its SPIRV-Tools environment here");
  return SPV_ENV_VULKAN_1_1;
}

// A module that passed a step, and whether legalizing it took SPIRV-Tools' full recipe (the core one was not enough:
// see legalize_spirv_core).
struct SpirvModule {
  std::vector<uint32_t> spirv;
  bool full_legalization = false;
};
// Why a step failed: the step (Legalize, Validate, Optimize, ValidateOptimized, CombineImageSamplers) and
// SPIRV-Tools' messages.
struct SpirvFailure {
  CompileStep step = CompileStep::None;
  std::vector<std::string> messages;
};
using SpirvResult = Result<SpirvModule, SpirvFailure>;

// The whole chain; a failure names the step that failed. With `optimize`, legalization tries the core
// recipe first and falls back to SPIRV-Tools' full one when the result does not validate; `recipe` says
// which optimization recipe follows (kiln's runs only after the core legalization recipe: a module that
// needed the full one gets -O).
// `legalized`, when given, is called between legalization (validated) and optimization: the worker's step times.
SpirvResult legalize_validate_optimize(std::vector<uint32_t> spirv, bool optimize, OptimizerRecipe recipe = OptimizerRecipe::Kiln,
                                       const std::function<void()>& legalized = {});
// Its steps alone (kiln-compile-steps times them): SPIRV-Tools' full legalization recipe (`spirv-opt
// --legalize-hlsl`), kiln's core legalization recipe (its first sixteen passes), and an optimization recipe
// (kiln's, or `spirv-opt -O`'s); none validates. Kiln's recipe expects the core legalization recipe's output.
SpirvResult legalize_spirv(const std::vector<uint32_t>& spirv);
SpirvResult legalize_spirv_core(const std::vector<uint32_t>& spirv);
SpirvResult optimize_spirv(const std::vector<uint32_t>& spirv, OptimizerRecipe recipe);
// What kiln's recipe assumes of its input, checked on every module (kiln runs -O on a module without it): no
// function call, every function an entry point, no Private variable, at most one return per function and in
// its last block. True of what the core legalization recipe gives for kiln's modules unless it could not
// inline a call.
bool fits_kiln_recipe(const std::vector<uint32_t>& spirv);
// The passes of the core legalization recipe and of each optimization recipe, by SPIRV-Tools' pass names, in
// order (kiln --version, the per-pass benchmark).
std::vector<std::string> legalization_pass_names();
std::vector<std::string> optimizer_pass_names(OptimizerRecipe recipe);
// The module with its result IDs renumbered densely in order of appearance (SPIRV-Tools' compact-ids): two
// recipes that make the same instructions with other ID numbers give the same words after it.
std::vector<uint32_t> compact_ids(const std::vector<uint32_t>& spirv);
// spirv-val alone (used by lint and tests).
Result<void, SpirvFailure> validate_spirv(const std::vector<uint32_t>& spirv);
// Every texture and sampler variable that share one (set, binding) become one combined image sampler
// (SPIRV-Tools' convert-to-sampled-image pass; a texture array and its sampler one array of them, by kiln's
// combine_texture_arrays), then validated. Step "combine-image-samplers".
SpirvResult combine_image_samplers(const std::vector<uint32_t>& spirv);
std::string disassemble_spirv(const std::vector<uint32_t>& spirv);
std::string spirv_tools_version();

}  // namespace kiln
