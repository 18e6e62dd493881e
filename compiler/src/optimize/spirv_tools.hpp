// Stage 5 (after the front end): legalize HLSL-derived SPIR-V, validate, optimize, validate again.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace kiln {

struct SpirvStepResult {
  bool ok = false;
  std::string step;  // "legalize", "validate", "optimize", "validate-optimized"
  std::vector<std::string> messages;
  std::vector<uint32_t> spirv;
};

// The whole chain; on failure `step` names the step that failed.
SpirvStepResult legalize_validate_optimize(std::vector<uint32_t> spirv, bool optimize);
// Its steps alone (kiln-compile-steps times them): SPIRV-Tools' legalization recipe, and the performance
// recipe (`spirv-opt -O`); neither validates.
SpirvStepResult legalize_spirv(const std::vector<uint32_t>& spirv);
SpirvStepResult optimize_spirv(const std::vector<uint32_t>& spirv);
// spirv-val alone (used by lint and tests).
SpirvStepResult validate_spirv(const std::vector<uint32_t>& spirv);
std::string disassemble_spirv(const std::vector<uint32_t>& spirv);
std::string spirv_tools_version();

}  // namespace kiln
