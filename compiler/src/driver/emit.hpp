// SPDX-License-Identifier: Apache-2.0
// Dumps for debugging (--emit), named <pass>/<stage>/<keywords>.<ext> under <output>/emit. Written for failed
// builds too, which is when they are wanted: whatever each stage source got to (its preprocessed text, and its
// outputs when it compiled).
#pragma once

#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include "driver/plan.hpp"
#include "driver/stage_sources.hpp"

namespace kiln {

// `emit`: the dumps asked for (--emit), written under `output_dir`/emit.
void emit_dumps(BuildContext& build, const Plan& plan, const StageSources& sources, const std::vector<Binary>& binaries,
                const std::set<std::string>& emit, const std::filesystem::path& output_dir);

}  // namespace kiln
