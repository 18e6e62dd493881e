// SPDX-License-Identifier: Apache-2.0
#include "cross/targets.hpp"

#include <spirv_cross/spirv_cross_c.h>

#include <cstdlib>
#include <stdexcept>

#include "cross/widen_float16.hpp"
#include "optimize/spirv_tools.hpp"
#include "spirv_cross_fingerprint.hpp"  // generated: KILN_SPIRV_CROSS_LIBRARIES_SHA256

namespace kiln {

// One file each, <id>_target.cpp, defining k<Enumerator>Target: one per KILN_CROSS_TARGET row of kiln/targets.def.
#define KILN_CROSS_TARGET(Enumerator, ...) extern const TargetBackend k##Enumerator##Target;
#include "kiln/targets.def"

namespace {

const TargetBackend* const kBackends[] = {
#define KILN_CROSS_TARGET(Enumerator, ...) &k##Enumerator##Target,
#include "kiln/targets.def"
};

// Each back end translates to the target its row names (k<Enumerator>Target for Target::Enumerator).
bool backends_match_their_rows() {
  for (size_t i = 0; i < std::size(kBackends); ++i)
    if (!kTargetNames[static_cast<size_t>(kBackends[i]->target)].cross_compiled ||
        cross_step(kBackends[i]->target) == CompileStep::None)
      return false;
  return true;
}

}  // namespace

std::span<const TargetBackend> target_backends() {
  static const std::vector<TargetBackend> backends = [] {
    if (!backends_match_their_rows()) std::abort();  // a programming error in a back end's file, caught by every build test
    std::vector<TargetBackend> list;
    for (const TargetBackend* backend : kBackends) list.push_back(*backend);
    return list;
  }();
  return backends;
}

const TargetBackend* target_backend(Target target) {
  for (const TargetBackend& backend : target_backends())
    if (backend.target == target) return &backend;
  return nullptr;
}

const std::vector<uint32_t>& CrossModules::gl_spirv() {
  if (!gl_ready_) {
    gl_ready_ = true;
    // Explicit 16-bit floats become mediump 32-bit floats for GL (see widen_float16.hpp).
    Result<Widened> widened = widen_float16_for_gl(spirv_);
    if (!widened) {
      gl_error_ = "widening 16-bit floats for GL: " + widened.error().message;
    } else {
      if (widened->changed) {
        if (Result<void, SpirvFailure> valid = validate_spirv(widened->spirv); !valid) {
          gl_error_ = "widening 16-bit floats for GL produced invalid SPIR-V:";
          for (const auto& m : valid.error().messages) gl_error_ += " " + m;
        }
      }
      gl_spirv_ = std::move(widened->spirv);
    }
  }
  if (!gl_error_.empty()) throw std::runtime_error(gl_error_);
  return gl_spirv_;
}

Result<std::string> cross_compile(const TargetBackend& backend, CrossModules& modules, Reflection& reflection) {
  try {
    return backend.translate(modules, reflection);
  } catch (const std::exception& error) {
    return failure(error.what());
  }
}

std::string spirv_cross_version() {
  return "C API " + std::to_string(SPVC_C_API_VERSION_MAJOR) + "." + std::to_string(SPVC_C_API_VERSION_MINOR) + "." +
         std::to_string(SPVC_C_API_VERSION_PATCH) + ", libraries sha256 " +
         std::string(KILN_SPIRV_CROSS_LIBRARIES_SHA256).substr(0, 16);
}

}  // namespace kiln
