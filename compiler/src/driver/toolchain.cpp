// SPDX-License-Identifier: Apache-2.0
// kiln::toolchain_description (kiln/build.hpp): the tools every output depends on, as --version states them.
#include "cross/targets.hpp"
#include "frontend/frontend.hpp"
#include "kiln/build.hpp"
#include "optimize/spirv_tools.hpp"

namespace kiln {

std::string toolchain_description() {
  std::string text;
  for (const std::string& name : frontend_names())
    if (auto frontend = make_frontend(name)) text += "front end: " + frontend->name() + " " + frontend->version() + "\n";
  text += "SPIRV-Tools: " + spirv_tools_version() + "\n";
  const size_t stock = optimizer_pass_names(OptimizerRecipe::Stock).size();
  text += "optimizer recipe: kiln (default; -O without " + std::to_string(stock - optimizer_pass_names(OptimizerRecipe::Kiln).size()) +
          " of its " + std::to_string(stock) + " passes), O with --optimize=O\n";
  text += "SPIRV-Cross: " + spirv_cross_version() + "\n";
  return text;
}

}  // namespace kiln
