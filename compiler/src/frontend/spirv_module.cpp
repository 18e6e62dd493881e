// SPDX-License-Identifier: Apache-2.0
// glslang's copy of the SPIR-V header, with its opcode table (HasResultAndType). This file is kept out of unity
// builds (compiler/CMakeLists.txt): another file of the stage may include the header without the table first.
#define SPV_ENABLE_UTILITY_CODE
#include <glslang/SPIRV/spirv.hpp>

#include "frontend/spirv_module.hpp"

#include <algorithm>
#include <set>

namespace kiln::spirv_edit {
namespace {

bool is_annotation(uint32_t op) {
  switch (static_cast<spv::Op>(op)) {
    case spv::OpDecorate:
    case spv::OpMemberDecorate:
    case spv::OpDecorationGroup:
    case spv::OpGroupDecorate:
    case spv::OpGroupMemberDecorate:
    case spv::OpDecorateId:
    case spv::OpDecorateString:
    case spv::OpMemberDecorateString: return true;
    default: return false;
  }
}

}  // namespace

std::string Instruction::string_at(size_t at) const {
  std::string out;
  for (size_t w = at; w < words.size(); ++w)
    for (int b = 0; b < 4; ++b) {
      const char c = static_cast<char>((words[w] >> (8 * b)) & 0xff);
      if (c == 0) return out;
      out.push_back(c);
    }
  return out;
}

Instruction make(uint32_t op, std::vector<uint32_t> operands) {
  Instruction in;
  in.words.reserve(operands.size() + 1);
  in.words.push_back((static_cast<uint32_t>(operands.size() + 1) << 16) | op);
  in.words.insert(in.words.end(), operands.begin(), operands.end());
  return in;
}

Instruction make_with_string(uint32_t op, std::vector<uint32_t> operands, std::string_view text) {
  std::vector<uint32_t> packed((text.size() + 4) / 4, 0);  // NUL-terminated, padded to a word
  for (size_t i = 0; i < text.size(); ++i) packed[i / 4] |= static_cast<uint32_t>(static_cast<unsigned char>(text[i])) << (8 * (i % 4));
  operands.insert(operands.end(), packed.begin(), packed.end());
  return make(op, std::move(operands));
}

bool has_result_type(uint32_t op) {
  bool result = false, type = false;
  spv::HasResultAndType(static_cast<spv::Op>(op), &result, &type);
  return result && type;
}

bool has_result(uint32_t op) {
  bool result = false, type = false;
  spv::HasResultAndType(static_cast<spv::Op>(op), &result, &type);
  return result;
}

uint32_t result_of(const Instruction& in) {
  if (!has_result(in.op())) return 0;
  const size_t at = has_result_type(in.op()) ? 2 : 1;
  return at < in.words.size() ? in.words[at] : 0;
}

std::optional<Module> Module::parse(const std::vector<uint32_t>& words) {
  if (words.size() < 5 || words[0] != spv::MagicNumber) return std::nullopt;
  Module module;
  std::copy(words.begin(), words.begin() + 5, module.header_.begin());
  for (size_t at = 5; at < words.size();) {
    const uint32_t count = words[at] >> 16;
    if (count == 0 || at + count > words.size()) return std::nullopt;
    module.instructions_.push_back({std::vector<uint32_t>(words.begin() + static_cast<long>(at), words.begin() + static_cast<long>(at + count))});
    at += count;
  }
  return module;
}

std::vector<uint32_t> Module::words() const {
  std::vector<uint32_t> out(header_.begin(), header_.end());
  for (const Instruction& in : instructions_) out.insert(out.end(), in.words.begin(), in.words.end());
  return out;
}

std::map<uint32_t, size_t> Module::definitions() const {
  std::map<uint32_t, size_t> out;
  for (size_t i = 0; i < instructions_.size(); ++i)
    if (const uint32_t id = result_of(instructions_[i])) out[id] = i;
  return out;
}

std::string Module::name_of(uint32_t id) const {
  for (const Instruction& in : instructions_)
    if (in.op() == spv::OpName && in.words.size() > 2 && in.words[1] == id) return in.string_at(2);
  return {};
}

void Module::add_capability(uint32_t capability) {
  size_t last = 0;
  for (size_t i = 0; i < instructions_.size(); ++i)
    if (instructions_[i].op() == spv::OpCapability) {
      if (instructions_[i].words[1] == capability) return;
      last = i;
    }
  instructions_.insert(instructions_.begin() + static_cast<long>(last + 1), make(spv::OpCapability, {capability}));
}

void Module::add_extension(std::string_view name) {
  size_t after = 0;
  for (size_t i = 0; i < instructions_.size(); ++i) {
    const uint32_t op = instructions_[i].op();
    if (op == spv::OpExtension && instructions_[i].string_at(1) == name) return;
    if (op == spv::OpCapability || op == spv::OpExtension) after = i;
  }
  instructions_.insert(instructions_.begin() + static_cast<long>(after + 1), make_with_string(spv::OpExtension, {}, name));
}

// The index of the last instruction of the module's sections up to the debug names (with_annotations: up to the
// annotations). The layout: ... entry points, execution modes, debug strings and sources, names, processes (the
// last debug instructions), annotations, types and globals, functions.
size_t Module::end_of_header(bool with_annotations) const {
  size_t after = 0;
  for (size_t i = 0; i < instructions_.size(); ++i) {
    switch (static_cast<spv::Op>(instructions_[i].op())) {
      case spv::OpCapability: case spv::OpExtension: case spv::OpExtInstImport: case spv::OpMemoryModel:
      case spv::OpEntryPoint: case spv::OpExecutionMode: case spv::OpExecutionModeId: case spv::OpString:
      case spv::OpSource: case spv::OpSourceContinued: case spv::OpSourceExtension: case spv::OpName:
      case spv::OpMemberName: after = i; continue;
      case spv::OpModuleProcessed: if (with_annotations) after = i; continue;
      default: break;
    }
    if (!with_annotations || !is_annotation(instructions_[i].op())) break;
    after = i;
  }
  return after;
}

void Module::add_debug_name(Instruction name) {
  instructions_.insert(instructions_.begin() + static_cast<long>(end_of_header(false) + 1), std::move(name));
}

void Module::add_annotation(Instruction annotation) {
  instructions_.insert(instructions_.begin() + static_cast<long>(end_of_header(true) + 1), std::move(annotation));
}

void Module::add_declaration(Instruction declaration) {
  auto first_function = std::find_if(instructions_.begin(), instructions_.end(),
                                     [](const Instruction& in) { return in.op() == spv::OpFunction; });
  instructions_.insert(first_function, std::move(declaration));
}

void Module::forget(const std::vector<uint32_t>& ids) {
  const std::set<uint32_t> gone(ids.begin(), ids.end());
  std::erase_if(instructions_, [&](const Instruction& in) {
    const uint32_t op = in.op();
    return (op == spv::OpName || op == spv::OpMemberName || is_annotation(op)) && in.words.size() > 1 && gone.count(in.words[1]);
  });
}

}  // namespace kiln::spirv_edit
