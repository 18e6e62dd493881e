// What every output of a build depends on besides its sources: the tools (front end, SPIRV-Tools, SPIRV-Cross,
// kiln's compile job revision), the options and the targets. Every cache key starts with it, and so does the
// inputs hash that makes a no-change build a no-op.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "common/hash.hpp"
#include "driver/plan.hpp"
#include "frontend/frontend.hpp"
#include "kiln/build.hpp"

namespace kiln {

struct BuildSettings {
  std::unique_ptr<Frontend> frontend;
  std::string fingerprint;      // tools and their versions
  std::vector<Target> targets;  // sorted; SPIR-V always included
  std::string target_names;     // "spirv,glsl,..." as hashed
  bool optimize = true;

  // The start of every compile's cache key: what its output depends on besides its input (the pass gives the
  // entry point and the binding options).
  Hasher& add_compile_options(Hasher& hasher, const PassDefinition& pass, Stage stage) const;
};

// Nothing when the front end is unknown (reported).
std::optional<BuildSettings> choose_settings(const BuildOptions& options, const Plan& plan, DiagnosticSink& sink);

// The inputs hash: the tools, options, pack format (a pack another format version wrote is rebuilt) and the
// bytes of every file read.
std::string hash_inputs(const BuildSettings& settings, const Plan& plan, const BuildOptions& options);

}  // namespace kiln
