// SPDX-License-Identifier: Apache-2.0
// Stage 7, last: the fragment stage of every variant reads only what the stage before it writes (K1410). One
// implementation for `kiln build` (an error: Vulkan's rule for the interface between stages) and `kiln lint`
// (its interface-mismatch rule reports the build's K1410).
#pragma once

#include "kiln/diagnostics.hpp"
#include "layouts/layout_check.hpp"

namespace kiln {

// Reports each distinct pair of producer and fragment binaries that disagree, once, at the pass's definition.
// False when it reported anything.
bool check_stage_interfaces(const PassLayoutInput& input, DiagnosticSink& sink);

}  // namespace kiln
