// SPDX-License-Identifier: Apache-2.0
// Stage 6: SPIR-V to the source targets (GLSL 450, GLSL ES 3.10, MSL 2.1) with SPIRV-Cross, each back end behind
// one registry entry. Only ever called on modules that passed spirv-val (SPIRV-Cross crashes on some invalid ones).
//
// Adding a target: its row in kiln/targets.def (a KILN_CROSS_TARGET) and one file here, <id>_target.cpp, defining
// its TargetBackend as k<Enumerator>Target (see glsl_target.cpp); the build compiles that file and links the
// row's SPIRV-Cross library. When it records language options or bindings of its own, their fields in
// kiln/manifest.hpp (ManifestOptions, Reflection) and the manifest codec. docs/design.md counts the files.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "common/compile_step.hpp"
#include "kiln/manifest_json.hpp"
#include "kiln/model.hpp"
#include "kiln/result.hpp"

namespace kiln {

// The modules a back end starts from: the optimized module, and the module with its 16-bit floats widened for
// GL (widen_float16.hpp), made once on first use and validated.
class CrossModules {
 public:
  explicit CrossModules(const std::vector<uint32_t>& spirv) : spirv_(spirv) {}
  const std::vector<uint32_t>& spirv() const { return spirv_; }
  // Throws std::runtime_error when the widening fails or its result does not validate.
  const std::vector<uint32_t>& gl_spirv();

 private:
  const std::vector<uint32_t>& spirv_;
  bool gl_ready_ = false;
  std::vector<uint32_t> gl_spirv_;
  std::string gl_error_;  // why the GL module could not be made
};

struct TargetBackend {
  Target target;
  std::string_view language;  // "GLSL 450", for --version and docs
  // Records the options this back end translates with in the manifest.
  void (*record_options)(ManifestOptions& options);
  // One module to the target's source; fills the target's binding records in `reflection`. Throws
  // std::exception (SPIRV-Cross's CompilerError included) on failure.
  std::string (*translate)(CrossModules& modules, Reflection& reflection);
};

// The back ends, in Target order; SPIR-V has none (it is not cross-compiled).
std::span<const TargetBackend> target_backends();
const TargetBackend* target_backend(Target target);  // null for SPIR-V

// Runs `backend` on `modules`: the target's source, or the back end's exception as the error.
Result<std::string> cross_compile(const TargetBackend& backend, CrossModules& modules, Reflection& reflection);

// "C API 0.54.0, libraries sha256 <16 hex digits>": the header's API version and a hash of the linked
// libraries (SPIRV-Cross has no run-time version); part of every cache key and of the manifest.
std::string spirv_cross_version();

}  // namespace kiln
