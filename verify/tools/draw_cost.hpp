// SPDX-License-Identifier: Apache-2.0
// kiln-verify draw-cost: what drawing the same variants from differently folded packs costs (draw_cost.cpp).
#pragma once

#include <string>

namespace kiln::render {

int run_draw_cost(const std::string& config_file, const std::string& out_file);

}  // namespace kiln::render
