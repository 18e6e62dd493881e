// SPDX-License-Identifier: Apache-2.0
// Stage 5b, with --coverage (docs/coverage.md): after validation and optimization, each basic block of a module
// that carries source lines (a -g build) stores 1 into its own word of the coverage buffer (kiln/coverage_map.hpp)
// when it runs. Nothing else changes: the instrumented module computes what the plain one does. The reader's
// read_coverage_map recovers which lines each word stands for from the module itself.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "kiln/result.hpp"

namespace kiln {

struct InstrumentedModule {
  std::vector<uint32_t> spirv;
  uint32_t probes = 0;  // blocks instrumented
};

// An error (the message names why) when the module binds something of its own at the coverage buffer's set and
// binding, has no single entry point of a stage the buffer has a slot for, or has more blocks than the buffer holds.
Result<InstrumentedModule> instrument_coverage(const std::vector<uint32_t>& spirv);

}  // namespace kiln
