// SPDX-License-Identifier: Apache-2.0
#include "frontend/nonuniform.hpp"

#include <glslang/SPIRV/spirv.hpp>

#include <algorithm>
#include <cctype>
#include <map>
#include <set>

#include "frontend/spirv_module.hpp"

namespace kiln {
namespace {

using spirv_edit::Instruction;
using spirv_edit::make;

bool in_identifier(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; }

bool is_access_chain(uint32_t op) {
  return op == spv::OpAccessChain || op == spv::OpInBoundsAccessChain || op == spv::OpPtrAccessChain ||
         op == spv::OpInBoundsPtrAccessChain;
}

}  // namespace

std::optional<std::string> rewrite_nonuniform_index(std::string_view text) {
  constexpr std::string_view kName = "NonUniformResourceIndex";
  static_assert(kName.size() == kNonUniformMarker.size(), "the marker keeps the user's columns");
  std::optional<std::string> out;
  for (size_t at = text.find(kName); at != std::string_view::npos; at = text.find(kName, at + 1)) {
    const size_t end = at + kName.size();
    if ((at > 0 && (in_identifier(text[at - 1]) || text[at - 1] == '.')) || (end < text.size() && in_identifier(text[end]))) continue;
    size_t open = end;
    while (open < text.size() && (text[open] == ' ' || text[open] == '\t')) ++open;
    if (open >= text.size() || text[open] != '(') continue;
    // A declaration of a function of that name (a type word before it) is the text's own: leave the text alone.
    size_t before = at;
    while (before > 0 && (text[before - 1] == ' ' || text[before - 1] == '\t')) --before;
    if (before < at && before > 0 && in_identifier(text[before - 1])) {
      size_t word = before;
      while (word > 0 && in_identifier(text[word - 1])) --word;
      const std::string_view previous = text.substr(word, before - word);
      if (previous != "return" && previous != "else" && previous != "case") return std::nullopt;
    }
    if (!out) out.emplace(text);
    out->replace(at, kName.size(), kNonUniformMarker);
  }
  return out;
}

size_t decorate_nonuniform(std::vector<uint32_t>& spirv) {
  std::optional<spirv_edit::Module> parsed = spirv_edit::Module::parse(spirv);
  if (!parsed) return 0;  // not glslang's: left to the validator
  spirv_edit::Module& module = *parsed;
  std::vector<Instruction>& code = module.instructions();

  // The marker function, by its name (glslang's "kiln_NonUniformResIndex(u1;").
  uint32_t marker = 0;
  for (const Instruction& in : code)
    if (in.op() == spv::OpName && in.string_at(2).starts_with(std::string(kNonUniformMarker) + "(")) marker = in.words[1];
  if (marker == 0) return 0;

  // 1. Each marker call passes its argument on: `%r = OpFunctionCall %uint %marker %p` becomes `%r = OpLoad %uint %p`
  //    (glslang passes an `in` argument through a Function variable; a value is copied) and %r seeds the
  //    non-uniform values. The marker function goes, with the names and decorations of what it defined.
  std::set<uint32_t> tainted;
  {
    const std::map<uint32_t, size_t> definition = module.definitions();
    for (Instruction& in : code)
      if (in.op() == spv::OpFunctionCall && in.words.size() == 5 && in.words[3] == marker) {
        const uint32_t type = in.words[1], result = in.words[2], argument = in.words[4];
        auto it = definition.find(argument);
        const bool pointer = it != definition.end() && code[it->second].op() == spv::OpVariable;
        in = make(pointer ? spv::OpLoad : spv::OpCopyObject, {type, result, argument});
        tainted.insert(result);
      }
  }
  std::vector<uint32_t> marker_ids;
  bool in_marker = false;
  std::erase_if(code, [&](const Instruction& in) {
    if (in.op() == spv::OpFunction && in.words[2] == marker) in_marker = true;
    const bool drop = in_marker;
    if (drop && spirv_edit::result_of(in)) marker_ids.push_back(spirv_edit::result_of(in));
    if (in.op() == spv::OpFunctionEnd) in_marker = false;
    return drop;
  });
  module.forget(marker_ids);

  std::map<uint32_t, size_t> definition = module.definitions();
  auto defining = [&](uint32_t id) -> const Instruction* {
    auto it = definition.find(id);
    return it == definition.end() ? nullptr : &code[it->second];
  };
  std::map<uint32_t, std::vector<uint32_t>> parameters;  // function -> its parameters
  {
    uint32_t function = 0;
    for (const Instruction& in : code) {
      if (in.op() == spv::OpFunction) function = in.words[2];
      if (in.op() == spv::OpFunctionParameter) parameters[function].push_back(in.words[2]);
    }
  }
  // The variable a pointer is derived from (through access chains and copies).
  auto root = [&](uint32_t id) {
    for (int depth = 0; depth < 64; ++depth) {
      const Instruction* in = defining(id);
      if (!in || !(is_access_chain(in->op()) || in->op() == spv::OpCopyObject)) break;
      id = in->words[3];
    }
    return id;
  };

  // 2. Follow the values to a fixed point: a result computed from a non-uniform operand is non-uniform; a store of
  //    one makes its variable's later loads non-uniform; an argument makes its parameter non-uniform, a returned
  //    value its calls. Over-approximate (every load of such a variable), which can only add decorations.
  std::set<uint32_t> tainted_memory;   // variables a non-uniform value was stored into
  std::set<uint32_t> tainted_returns;  // functions that return a non-uniform value
  for (bool changed = true; changed;) {
    changed = false;
    auto taint = [&](std::set<uint32_t>& set, uint32_t id) { changed = set.insert(id).second || changed; };
    uint32_t function = 0;
    for (const Instruction& in : code) {
      const uint32_t op = in.op();
      if (op == spv::OpFunction) function = in.words[2];
      if (op == spv::OpStore && in.words.size() >= 3 && tainted.count(in.words[2])) taint(tainted_memory, root(in.words[1]));
      if (op == spv::OpReturnValue && tainted.count(in.words[1])) taint(tainted_returns, function);
      if (!spirv_edit::has_result_type(op) || in.words.size() < 3) continue;
      const uint32_t result = in.words[2];
      if (op == spv::OpFunctionCall) {
        const std::vector<uint32_t>& params = parameters[in.words[3]];
        for (size_t a = 4; a < in.words.size() && a - 4 < params.size(); ++a)
          if (tainted.count(in.words[a]) || tainted_memory.count(root(in.words[a]))) {
            taint(tainted, params[a - 4]);
            taint(tainted_memory, params[a - 4]);
          }
        if (tainted_returns.count(in.words[3])) taint(tainted, result);
        continue;
      }
      if (tainted.count(result) || op == spv::OpVariable || op == spv::OpFunctionParameter) continue;
      if (op == spv::OpLoad && tainted_memory.count(root(in.words[3]))) {
        taint(tainted, result);
        continue;
      }
      for (size_t w = 3; w < in.words.size(); ++w)
        if (tainted.count(in.words[w])) {
          taint(tainted, result);
          break;
        }
    }
  }

  // 3. Decorate the resource accesses: an access chain that selects an element of a descriptor array by a
  //    non-uniform index (and chains on from it), what is loaded through it, and the images and sampled images
  //    made from those. To a fixed point: glslang's blocks need not come in dominance order.
  auto storage_class = [&](uint32_t variable) -> std::optional<uint32_t> {
    const Instruction* in = defining(variable);
    if (!in || in->op() != spv::OpVariable) return std::nullopt;
    return in->words[3];
  };
  auto pointee = [&](uint32_t pointer_type) -> const Instruction* {
    const Instruction* in = defining(pointer_type);
    return in && in->op() == spv::OpTypePointer ? defining(in->words[3]) : nullptr;
  };
  // The element type of a descriptor array variable (UniformConstant, Uniform or StorageBuffer), or null.
  auto descriptor_array_element = [&](uint32_t variable) -> const Instruction* {
    const std::optional<uint32_t> sc = storage_class(variable);
    if (!sc || !(*sc == spv::StorageClassUniformConstant || *sc == spv::StorageClassUniform || *sc == spv::StorageClassStorageBuffer))
      return nullptr;
    const Instruction* array = pointee(defining(variable)->words[1]);
    if (!array || (array->op() != spv::OpTypeArray && array->op() != spv::OpTypeRuntimeArray)) return nullptr;
    return defining(array->words[2]);
  };
  std::set<uint32_t> decorated, arrays;  // arrays: the descriptor array variables indexed non-uniformly
  for (bool changed = true; changed;) {
    changed = false;
    for (const Instruction& in : code) {
      const uint32_t op = in.op();
      if (!spirv_edit::has_result_type(op) || in.words.size() < 4 || decorated.count(in.words[2])) continue;
      bool decorate = false;
      if (is_access_chain(op)) {
        const uint32_t base = in.words[3];
        if (decorated.count(base)) {
          decorate = true;
        } else if (in.words.size() >= 5 && tainted.count(in.words[4]) && descriptor_array_element(base)) {
          decorate = true;
          arrays.insert(base);
        }
      } else if (op == spv::OpLoad || op == spv::OpImageTexelPointer) {
        decorate = decorated.count(in.words[3]) > 0;
      } else if (op == spv::OpSampledImage || op == spv::OpImage) {
        decorate = decorated.count(in.words[3]) || (op == spv::OpSampledImage && decorated.count(in.words[4]));
      }
      if (decorate) changed = decorated.insert(in.words[2]).second || changed;
    }
  }

  // 4. The capabilities: ShaderNonUniform, and for each kind of descriptor array indexed non-uniformly its own.
  std::set<uint32_t> buffer_blocks;  // struct types decorated BufferBlock (storage buffers of SPIR-V 1.0-1.2)
  for (const Instruction& in : code)
    if (in.op() == spv::OpDecorate && in.words.size() >= 3 && in.words[2] == spv::DecorationBufferBlock) buffer_blocks.insert(in.words[1]);
  std::set<uint32_t> capabilities;
  for (uint32_t variable : arrays) {
    const Instruction& element = *descriptor_array_element(variable);
    if (element.op() == spv::OpTypeSampler || element.op() == spv::OpTypeSampledImage) {
      capabilities.insert(spv::CapabilitySampledImageArrayNonUniformIndexing);
    } else if (element.op() == spv::OpTypeImage && element.words.size() >= 9) {
      const uint32_t dim = element.words[3];
      const bool storage = element.words[7] == 2;
      if (dim == spv::DimSubpassData) capabilities.insert(spv::CapabilityInputAttachmentArrayNonUniformIndexing);
      else if (dim == spv::DimBuffer)
        capabilities.insert(storage ? spv::CapabilityStorageTexelBufferArrayNonUniformIndexing
                                    : spv::CapabilityUniformTexelBufferArrayNonUniformIndexing);
      else
        capabilities.insert(storage ? spv::CapabilityStorageImageArrayNonUniformIndexing
                                    : spv::CapabilitySampledImageArrayNonUniformIndexing);
    } else if (element.op() == spv::OpTypeStruct) {
      const bool storage = *storage_class(variable) == spv::StorageClassStorageBuffer || buffer_blocks.count(element.words[1]);
      capabilities.insert(storage ? spv::CapabilityStorageBufferArrayNonUniformIndexing
                                  : spv::CapabilityUniformBufferArrayNonUniformIndexing);
    }
  }
  if (!decorated.empty()) {
    module.add_capability(spv::CapabilityShaderNonUniform);
    for (uint32_t capability : capabilities) module.add_capability(capability);
    if (module.version() < 0x00010500u) module.add_extension("SPV_EXT_descriptor_indexing");
    for (uint32_t id : decorated) module.add_annotation(make(spv::OpDecorate, {id, spv::DecorationNonUniform}));
  }
  spirv = module.words();
  return decorated.size();
}

}  // namespace kiln
