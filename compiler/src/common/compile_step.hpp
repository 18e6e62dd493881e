// The steps of a compile, as a failure names them. The worker protocol carries the name; the build maps each
// step to one diagnostic (driver/compile.cpp), so a new step that is not mapped is a compile error (-Wswitch).
#pragma once

#include <optional>
#include <string_view>

#include "kiln/model.hpp"

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
  Reflect,
  CrossGlsl,
  CrossGles,
  CrossMsl,
  OutOfMemory,        // the worker ran out of memory during the job
  Internal,           // the worker threw: a bug in kiln
};

// "validate-optimized", "cross-msl", ... ("" for None).
std::string_view step_name(CompileStep step);
std::optional<CompileStep> parse_step(std::string_view name);

}  // namespace kiln
