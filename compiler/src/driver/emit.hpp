// Dumps for debugging (--emit), named <pass>/<stage>/<keywords>.<ext> under <output>/emit. Written for failed
// builds too, which is when they are wanted: whatever each stage source got to (its preprocessed text, and its
// outputs when it compiled).
#pragma once

#include <vector>

#include "driver/plan.hpp"
#include "driver/stage_sources.hpp"

namespace kiln {

void emit_dumps(const Plan& plan, const StageSources& sources, const std::vector<Binary>& binaries,
                const BuildOptions& options, DiagnosticSink& sink, BuildReport& report);

}  // namespace kiln
