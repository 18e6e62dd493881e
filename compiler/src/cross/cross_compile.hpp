// Stage 6: SPIR-V to GLSL 450, GLSL ES 3.10 and MSL 2.1 (macOS) with SPIRV-Cross.
// Only ever called on modules that passed spirv-val (SPIRV-Cross crashes on some invalid ones).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "kiln/manifest.hpp"
#include "kiln/model.hpp"

namespace kiln {

struct CrossResult {
  bool ok = false;
  std::string error;
  std::string source;
  // The target's binding records: GL combined image-samplers and blocks, MSL resource indices.
  std::optional<GlBindings> gl;
  std::optional<MslBindings> msl;
};

// One module to every target. The GL targets compile the module with its 16-bit floats widened to mediump
// (widen_float16.hpp); the widening, and the validation of its result, happen once for GLSL and GLSL ES.
class CrossCompiler {
 public:
  explicit CrossCompiler(const std::vector<uint32_t>& spirv) : spirv_(spirv) {}
  CrossResult compile(Target target);

 private:
  const std::vector<uint32_t>& spirv_;
  bool gl_ready_ = false;
  std::vector<uint32_t> gl_spirv_;
  std::string gl_error_;  // why the GL module could not be made
};

// "C API 0.54.0, libraries sha256 <16 hex digits>": the header's API version and a hash of the linked
// libraries (SPIRV-Cross has no run-time version); part of every cache key and of the manifest.
std::string spirv_cross_version();

}  // namespace kiln
