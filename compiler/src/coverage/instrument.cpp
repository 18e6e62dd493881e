// SPDX-License-Identifier: Apache-2.0
#include "coverage/instrument.hpp"

#include <glslang/SPIRV/spirv.hpp>

#include <algorithm>
#include <map>
#include <optional>

#include "frontend/spirv_module.hpp"
#include "kiln/coverage_map.hpp"

namespace kiln {
namespace {

using spirv_edit::Instruction;
using spirv_edit::make;

bool ends_block(uint32_t op) {
  switch (static_cast<spv::Op>(op)) {
    case spv::OpBranch: case spv::OpBranchConditional: case spv::OpSwitch: case spv::OpKill: case spv::OpReturn:
    case spv::OpReturnValue: case spv::OpUnreachable: case spv::OpTerminateInvocation: return true;
    default: return false;
  }
}

// Whether a fragment shader may test depth before it runs: nothing it does decides the depth test (no discard, no
// depth, stencil or sample-mask output).
bool tests_depth_late_for_its_own_reasons(const std::vector<Instruction>& code) {
  for (const Instruction& in : code) {
    switch (static_cast<spv::Op>(in.op())) {
      case spv::OpKill: case spv::OpTerminateInvocation: case spv::OpDemoteToHelperInvocation: return true;
      case spv::OpDecorate:
        if (in.words.size() > 3 && in.words[2] == spv::DecorationBuiltIn &&
            (in.words[3] == spv::BuiltInFragDepth || in.words[3] == spv::BuiltInSampleMask || in.words[3] == spv::BuiltInFragStencilRefEXT))
          return true;
        break;
      default: break;
    }
  }
  return false;
}

// What must stay at the top of a block, before the probe's store.
bool starts_block(uint32_t op) {
  return op == spv::OpPhi || op == spv::OpVariable || op == spv::OpLine || op == spv::OpNoLine;
}

}  // namespace

Result<InstrumentedModule> instrument_coverage(const std::vector<uint32_t>& words) {
  std::optional<spirv_edit::Module> parsed = spirv_edit::Module::parse(words);
  if (!parsed) return failure("not a well-formed SPIR-V module");
  spirv_edit::Module& module = *parsed;
  std::vector<Instruction>& code = module.instructions();

  // The stage's slot, and nothing of the module's own where the buffer goes.
  size_t entry_point = code.size();
  std::map<uint32_t, uint32_t> sets, bindings;
  uint32_t uint_type = 0;
  for (size_t i = 0; i < code.size(); ++i) {
    const Instruction& in = code[i];
    if (in.op() == spv::OpEntryPoint && in.words.size() > 2) {
      if (entry_point != code.size()) return failure("the module has more than one entry point");
      entry_point = i;
    } else if (in.op() == spv::OpDecorate && in.words.size() > 3) {
      if (in.words[2] == spv::DecorationDescriptorSet) sets[in.words[1]] = in.words[3];
      if (in.words[2] == spv::DecorationBinding) bindings[in.words[1]] = in.words[3];
    } else if (in.op() == spv::OpTypeInt && in.words.size() == 4 && in.words[2] == 32 && in.words[3] == 0) {
      uint_type = in.words[1];
    }
  }
  if (entry_point == code.size()) return failure("the module has no entry point");
  const uint32_t slot = code[entry_point].words[1];  // spv::ExecutionModel: Vertex 0 ... GLCompute 5
  if (slot > spv::ExecutionModelGLCompute) return failure("the coverage buffer has no slot for this entry point's stage");
  for (const auto& [id, binding] : bindings)
    if (binding == kCoverageBinding && sets[id] == kCoverageSet) {
      const std::string name = module.name_of(id);
      return failure("binding " + std::to_string(kCoverageBinding) + " of set " + std::to_string(kCoverageSet) +
                     ", where --coverage puts its buffer, is taken by '" + (name.empty() ? "%" + std::to_string(id) : name) + "'");
    }

  // The blocks that carry lines: the probes.
  std::vector<uint32_t> probe_labels;  // label ids, in module order
  for (size_t i = 0; i < code.size(); ++i) {
    if (code[i].op() != spv::OpLabel || code[i].words.size() < 2) continue;
    for (size_t j = i + 1; j < code.size() && !ends_block(code[j].op()); ++j)
      if (code[j].op() == spv::OpLine) {
        probe_labels.push_back(code[i].words[1]);
        break;
      }
  }
  if (uint64_t{probe_labels.size()} * kCoverageStageSlots > kCoverageBufferWords)
    return failure("the module has " + std::to_string(probe_labels.size()) + " blocks, more than the coverage buffer holds (" +
                   std::to_string(kCoverageBufferWords / kCoverageStageSlots) + ")");

  // The buffer: struct KilnCoverage { uint hits[]; } in StorageBuffer, set and binding of kiln/coverage_map.hpp.
  if (!uint_type) {
    uint_type = module.new_id();
    module.add_declaration(make(spv::OpTypeInt, {uint_type, 32, 0}));
  }
  const uint32_t hits = module.new_id(), block = module.new_id(), block_pointer = module.new_id(),
                 word_pointer = module.new_id(), buffer = module.new_id(), zero = module.new_id(), one = module.new_id();
  module.add_declaration(make(spv::OpTypeRuntimeArray, {hits, uint_type}));
  module.add_declaration(make(spv::OpTypeStruct, {block, hits}));
  module.add_declaration(make(spv::OpTypePointer, {block_pointer, spv::StorageClassStorageBuffer, block}));
  module.add_declaration(make(spv::OpTypePointer, {word_pointer, spv::StorageClassStorageBuffer, uint_type}));
  module.add_declaration(make(spv::OpVariable, {block_pointer, buffer, spv::StorageClassStorageBuffer}));
  module.add_declaration(make(spv::OpConstant, {uint_type, zero, 0}));
  module.add_declaration(make(spv::OpConstant, {uint_type, one, 1}));
  std::vector<uint32_t> word_ids;
  for (size_t p = 0; p < probe_labels.size(); ++p) {
    word_ids.push_back(module.new_id());
    module.add_declaration(make(spv::OpConstant, {uint_type, word_ids.back(), static_cast<uint32_t>(p * kCoverageStageSlots + slot)}));
  }
  module.add_annotation(make(spv::OpDecorate, {hits, spv::DecorationArrayStride, 4}));
  module.add_annotation(make(spv::OpDecorate, {block, spv::DecorationBlock}));
  module.add_annotation(make(spv::OpMemberDecorate, {block, 0, spv::DecorationOffset, 0}));
  module.add_annotation(make(spv::OpDecorate, {buffer, spv::DecorationDescriptorSet, kCoverageSet}));
  module.add_annotation(make(spv::OpDecorate, {buffer, spv::DecorationBinding, kCoverageBinding}));
  module.add_debug_name(spirv_edit::make_with_string(spv::OpName, {block}, kCoverageBufferName));  // GL names blocks by their type
  module.add_debug_name(spirv_edit::make_with_string(spv::OpMemberName, {block, 0}, "hits"));
  module.add_debug_name(spirv_edit::make_with_string(spv::OpName, {buffer}, kCoverageBufferName));
  if (module.version() < 0x10300) module.add_extension("SPV_KHR_storage_buffer_storage_class");
  // A fragment shader that writes memory runs for every fragment, hidden or not, unless it asks for the depth test
  // first: with it, the probes count the fragments that pass the depth test (not those a nearer surface already
  // hides), and hidden fragments cost nothing (bench/REPORT.md, "Shader code coverage"). The image is the same:
  // nothing in such a shader decides the depth test.
  const bool early_already = std::any_of(code.begin(), code.end(), [](const Instruction& in) {
    return in.op() == spv::OpExecutionMode && in.words.size() > 2 && in.words[2] == spv::ExecutionModeEarlyFragmentTests;
  });
  if (slot == spv::ExecutionModelFragment && !early_already && !tests_depth_late_for_its_own_reasons(code)) {
    auto entry = std::find_if(code.begin(), code.end(), [](const Instruction& in) { return in.op() == spv::OpEntryPoint; });
    const uint32_t function = entry->words[2];
    code.insert(entry + 1, make(spv::OpExecutionMode, {function, spv::ExecutionModeEarlyFragmentTests}));
  }
  if (module.version() >= 0x10400)  // the interface lists every global the entry point uses
    for (Instruction& in : code)
      if (in.op() == spv::OpEntryPoint) {
        in.words.push_back(buffer);
        in.words[0] = (static_cast<uint32_t>(in.words.size()) << 16) | in.op();
      }

  // Each probe's store, at the top of its block (after its phis and variables).
  std::map<uint32_t, uint32_t> word_of_label;
  for (size_t p = 0; p < probe_labels.size(); ++p) word_of_label[probe_labels[p]] = word_ids[p];
  std::vector<Instruction> instrumented;
  instrumented.reserve(code.size() + 2 * probe_labels.size());
  for (size_t i = 0; i < code.size();) {
    auto probe = code[i].op() == spv::OpLabel ? word_of_label.find(code[i].words[1]) : word_of_label.end();
    instrumented.push_back(std::move(code[i++]));
    if (probe == word_of_label.end()) continue;
    while (i < code.size() && starts_block(code[i].op())) instrumented.push_back(std::move(code[i++]));
    const uint32_t pointer = module.new_id();
    instrumented.push_back(make(spv::OpAccessChain, {word_pointer, pointer, buffer, zero, probe->second}));
    instrumented.push_back(make(spv::OpStore, {pointer, one}));
  }
  code = std::move(instrumented);
  return InstrumentedModule{module.words(), static_cast<uint32_t>(probe_labels.size())};
}

}  // namespace kiln
