// SPDX-License-Identifier: Apache-2.0
// The steps of a compile, as a failure names them. The worker protocol carries the name; the build maps each
// step to one diagnostic (driver/compile.cpp), so a new step that is not mapped is a compile error (-Wswitch).
#pragma once

#include <optional>
#include <string_view>

#include "kiln/model.hpp"
#include "kiln/stage_target.hpp"

namespace kiln {

enum class CompileStep {
  None,               // did not fail
  Preprocess,
  Frontend,           // the HLSL front end rejected the source
  EntryPoint,         // the entry point is not defined
  Legalize,
  CombineImageSamplers,  // --combined-image-samplers: textures and samplers at one register become one binding
  Validate,           // spirv-val on the legalized module
  Optimize,
  ValidateOptimized,  // spirv-val on the optimized module
  Instrument,         // --coverage: the coverage probes (coverage/instrument.hpp), validated again
  Reflect,
  // Cross<Enumerator> for each SPIRV-Cross back end (kiln/targets.def), named "cross-<id>".
#define KILN_CROSS_TARGET(Enumerator, ...) Cross##Enumerator,
#include "kiln/targets.def"
  OutOfMemory,        // the worker ran out of memory during the job
  Internal,           // the worker threw: a bug in kiln
};

// "validate-optimized", "cross-msl", ... ("" for None).
std::string_view step_name(CompileStep step);
std::optional<CompileStep> parse_step(std::string_view name);

// The step a failure of `target`'s back end is reported as (CompileStep::None for SPIR-V, which is not cross-compiled).
CompileStep cross_step(Target target);

}  // namespace kiln
