// SPDX-License-Identifier: Apache-2.0
// Stage 7, second half: every variant and stage of a pass must agree on its resource layout (K1406).
// A clash is reported once per root cause, at the HLSL declarations involved, saying whether the stages
// of one variant or different variants disagree, how many variants it affects, and what fixes it.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <optional>

#include "kiln/diagnostics.hpp"
#include "kiln/manifest_json.hpp"
#include "kiln/model.hpp"

namespace kiln {

struct PassLayoutInput {
  std::string pass;
  SourceLocation pass_location;           // where the pass is defined: when a declaration cannot be found
  std::vector<std::string> variant_names;  // per variant of the pass: its keywords, "A B" or "<none>"
  struct Binary {
    Stage stage = Stage::Vertex;
    const Reflection* reflection = nullptr;
    std::vector<size_t> variants;  // the variants (indices into variant_names) that use this binary
  };
  std::vector<Binary> binaries;
  // Where the pass's sources declare a resource (path 0 line when not found).
  std::function<SourceLocation(const std::string& name)> locate;
  // Where a stage's sources (its entry file first) declare an input or output variable (path 0 line when not found).
  std::function<SourceLocation(const std::string& name, Stage stage)> locate_stage_variable;
  // Whether "combined_image_samplers" is on for a stage of the pass: a clash's advice never suggests what is in force.
  bool combined_image_samplers = false;
};

// The pass's merged layout; nothing when it has clashes (each reported to `sink`).
std::optional<PassLayout> check_pass_layout(const PassLayoutInput& input, DiagnosticSink& sink);

}  // namespace kiln
