// Stage 7: reflect descriptor sets, bindings, push constants, vertex inputs and block member offsets,
// and check that every variant and stage of a pass agrees on them.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "kiln/diagnostics.hpp"

namespace kiln {

// A module whose layout cannot be reflected truthfully (a block of 4 GiB or more).
struct ReflectionError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// {"resources": [...], "push_constants": [...], "inputs": [...], "outputs": [...]}, sorted, deterministic.
// Throws ReflectionError.
nlohmann::json reflect_spirv(const std::vector<uint32_t>& spirv);

// One reflected binary of a pass, with a description of where it came from for messages.
struct LayoutSource {
  std::string description;  // "Forward fragment [A B]"
  const nlohmann::json* reflection;
};

// Merges the resources of all binaries of a pass into one layout; a binding that means two different
// things, a resource at two bindings or two different block layouts under one name are LayoutMismatch
// errors. Returns the merged layout.
nlohmann::json merge_pass_layout(const std::string& pass, const std::vector<LayoutSource>& sources,
                                 const SourceLocation& pass_location, DiagnosticSink& sink);

}  // namespace kiln
