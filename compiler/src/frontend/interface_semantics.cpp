// SPDX-License-Identifier: Apache-2.0
#include "frontend/interface_semantics.hpp"

#include <glslang/SPIRV/spirv.hpp>

#include <algorithm>

#include "frontend/spirv_module.hpp"

namespace kiln {
namespace {

using spirv_edit::Instruction;

constexpr std::string_view kExtension = "SPV_GOOGLE_hlsl_functionality1";

bool is_semantic(const Instruction& in) {
  return in.op() == spv::OpDecorateString && in.words.size() > 3 && in.words[2] == static_cast<uint32_t>(spv::DecorationUserSemantic);
}

}  // namespace

Result<void> attach_interface_semantics(std::vector<uint32_t>& spirv, const InterfaceSemantics& semantics) {
  if (semantics.empty()) return {};
  std::optional<spirv_edit::Module> parsed = spirv_edit::Module::parse(spirv);
  if (!parsed) return failure("glslang's module does not parse");
  spirv_edit::Module& module = *parsed;
  std::vector<Instruction> decorations;
  for (const Instruction& in : module.instructions()) {
    if (in.op() != spv::OpVariable || in.words.size() < 4) continue;
    if (in.words[3] != spv::StorageClassInput && in.words[3] != spv::StorageClassOutput) continue;
    const auto found = semantics.find(module.name_of(in.words[2]));
    if (found != semantics.end())
      decorations.push_back(spirv_edit::make_with_string(spv::OpDecorateString, {in.words[2], static_cast<uint32_t>(spv::DecorationUserSemantic)}, found->second));
  }
  if (decorations.empty()) return {};
  module.add_extension(kExtension);
  for (Instruction& decoration : decorations) module.add_annotation(std::move(decoration));
  spirv = module.words();
  return {};
}

InterfaceSemantics detach_interface_semantics(std::vector<uint32_t>& spirv) {
  InterfaceSemantics semantics;
  std::optional<spirv_edit::Module> parsed = spirv_edit::Module::parse(spirv);
  if (!parsed) return semantics;  // the back end's own checks report a module that does not parse
  spirv_edit::Module& module = *parsed;
  std::vector<Instruction>& code = module.instructions();
  if (std::none_of(code.begin(), code.end(), is_semantic)) return semantics;
  for (const Instruction& in : code)
    if (is_semantic(in)) semantics[module.name_of(in.words[1])] = in.string_at(3);
  std::erase_if(code, [](const Instruction& in) {
    return is_semantic(in) || (in.op() == spv::OpExtension && in.string_at(1) == kExtension);
  });
  spirv = module.words();
  return semantics;
}

}  // namespace kiln
