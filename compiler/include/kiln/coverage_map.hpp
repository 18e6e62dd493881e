// SPDX-License-Identifier: Apache-2.0
// Shader code coverage (docs/coverage.md). `kiln build -g --coverage` instruments every SPIR-V module: each basic
// block that carries source lines stores a nonzero word into a storage buffer when it runs. A renderer binds that
// buffer, draws, reads it back, and asks the module's coverage map which HLSL lines ran. kiln test does; a game's
// own renderer can, through this header (part of the reader library).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "kiln/result.hpp"

namespace kiln {

// The buffer: a storage buffer of 32-bit words named kCoverageBufferName, at (kCoverageSet, kCoverageBinding) of
// the module (a module that already binds something there is refused by the build). kCoverageBufferWords words
// hold any module's probes; a renderer allocates that much, zeroed, per pass.
inline constexpr std::string_view kCoverageBufferName = "_KilnCoverage";
inline constexpr uint32_t kCoverageSet = 0;
inline constexpr uint32_t kCoverageBinding = 63;
inline constexpr uint32_t kCoverageBufferWords = uint32_t{1} << 20;
// The stages of one pipeline share the buffer: probe p of a stage writes word p * kCoverageStageSlots + the
// stage's slot (vertex 0, tessellation control 1, evaluation 2, geometry 3, fragment 4, compute 5).
inline constexpr uint32_t kCoverageStageSlots = 8;

// One basic block: the word it sets, and the source lines (index into CoverageMap::files, 1-based line) it holds.
struct CoverageProbe {
  uint32_t word = 0;
  std::vector<std::pair<uint32_t, uint32_t>> lines;
};

struct CoverageMap {
  std::vector<std::string> files;  // as the module's OpString names them (the include names of the build)
  std::vector<CoverageProbe> probes;
};

// The map of an instrumented module (its bytes, as a pack stores them); nothing for a module without the coverage
// buffer. A malformed module (truncated, an operand out of range, a word past kCoverageBufferWords) is an error.
Result<std::optional<CoverageMap>> read_coverage_map(std::string_view spirv);

}  // namespace kiln
