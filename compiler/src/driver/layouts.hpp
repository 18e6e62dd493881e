// SPDX-License-Identifier: Apache-2.0
// Stage 7 (second half): every variant and stage of a pass must agree on its resource layout, and each fragment
// stage must read what the stage before it writes.
#pragma once

#include <optional>
#include <vector>

#include "kiln/manifest_json.hpp"
#include "driver/messages.hpp"
#include "driver/plan.hpp"
#include "driver/stage_sources.hpp"

namespace kiln {

// Each pass's merged layout; nothing when a pass's binaries disagree or its stages' interfaces do not match
// (reported).
std::optional<std::vector<PassLayout>> check_pass_layouts(BuildContext& build, const Plan& plan,
                                                              const SourceLocator& locator, const StageSources& sources,
                                                              const std::vector<Binary>& binaries);

}  // namespace kiln
