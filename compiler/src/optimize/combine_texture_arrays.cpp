// SPDX-License-Identifier: Apache-2.0
#include "optimize/combine_texture_arrays.hpp"

#include "optimize/spirv_tools.hpp"  // spirv_tools_environment

#include <spirv-tools/libspirv.h>
#include <spirv_cross/spirv.hpp>  // the SPIR-V enums only

#include <algorithm>
#include <map>
#include <optional>
#include <string>

namespace kiln {
// A named namespace, not an anonymous one: the unity build puts the stage's files in one translation unit.
namespace texture_arrays {

// One instruction as SPIRV-Tools' parser gives it: its words, and which of them name an ID it uses.
struct Instruction {
  uint32_t opcode = 0;
  uint32_t result = 0;  // 0: none
  bool non_semantic = false;  // an OpExtInst of a non-semantic set (debug information): never a real use
  std::vector<uint32_t> words;
  std::vector<uint16_t> uses;  // word indices of ID operands other than the result
};

struct Module {
  std::vector<uint32_t> header;
  std::vector<Instruction> instructions;
};

bool non_semantic_set(spv_ext_inst_type_t set) {
  switch (set) {
    case SPV_EXT_INST_TYPE_DEBUGINFO:
    case SPV_EXT_INST_TYPE_OPENCL_DEBUGINFO_100:
    case SPV_EXT_INST_TYPE_NONSEMANTIC_CLSPVREFLECTION:
    case SPV_EXT_INST_TYPE_NONSEMANTIC_SHADER_DEBUGINFO_100:
    case SPV_EXT_INST_TYPE_NONSEMANTIC_UNKNOWN: return true;
    default: return false;
  }
}

spv_result_t parsed_instruction(void* user, const spv_parsed_instruction_t* parsed) {
  Instruction instruction;
  instruction.opcode = parsed->opcode;
  instruction.result = parsed->result_id;
  instruction.non_semantic = parsed->opcode == spv::OpExtInst && non_semantic_set(parsed->ext_inst_type);
  instruction.words.assign(parsed->words, parsed->words + parsed->num_words);
  for (uint16_t i = 0; i < parsed->num_operands; ++i)
    switch (parsed->operands[i].type) {
      case SPV_OPERAND_TYPE_ID:
      case SPV_OPERAND_TYPE_TYPE_ID:
      case SPV_OPERAND_TYPE_MEMORY_SEMANTICS_ID:
      case SPV_OPERAND_TYPE_SCOPE_ID: instruction.uses.push_back(parsed->operands[i].offset); break;
      default: break;
    }
  static_cast<Module*>(user)->instructions.push_back(std::move(instruction));
  return SPV_SUCCESS;
}

std::optional<Module> parse(const std::vector<uint32_t>& spirv) {
  if (spirv.size() < 5) return std::nullopt;
  Module module;
  module.header.assign(spirv.begin(), spirv.begin() + 5);
  spv_context context = spvContextCreate(spirv_tools_environment());
  const spv_result_t parsed = spvBinaryParse(context, &module, spirv.data(), spirv.size(), nullptr, parsed_instruction, nullptr);
  spvContextDestroy(context);
  if (parsed != SPV_SUCCESS) return std::nullopt;
  return module;
}

std::vector<uint32_t> words_of(const Module& module) {
  std::vector<uint32_t> words = module.header;
  for (const Instruction& instruction : module.instructions)
    words.insert(words.end(), instruction.words.begin(), instruction.words.end());
  return words;
}

// Names, decorations and the entry point's interface list mention a variable without using it.
bool annotation(uint32_t opcode) {
  switch (opcode) {
    case spv::OpName:
    case spv::OpMemberName:
    case spv::OpDecorate:
    case spv::OpMemberDecorate:
    case spv::OpDecorateId:
    case spv::OpDecorateString:
    case spv::OpMemberDecorateString:
    case spv::OpEntryPoint: return true;
    default: return false;
  }
}

Instruction make(spv::Op opcode, std::vector<uint32_t> operands, uint32_t result, std::vector<uint16_t> uses) {
  Instruction instruction;
  instruction.opcode = opcode;
  instruction.result = result;
  instruction.words.push_back(static_cast<uint32_t>(operands.size() + 1) << 16 | opcode);
  instruction.words.insert(instruction.words.end(), operands.begin(), operands.end());
  instruction.uses = std::move(uses);
  return instruction;
}

// Where an ID is used: (instruction index, word index).
using Use = std::pair<size_t, uint16_t>;

// What one module says about its IDs, for one slot's combining.
class Facts {
 public:
  explicit Facts(const Module& module) : module_(module) {
    for (size_t i = 0; i < module.instructions.size(); ++i) {
      const Instruction& instruction = module.instructions[i];
      const std::vector<uint32_t>& w = instruction.words;
      if (instruction.result) definition_[instruction.result] = i;
      if (instruction.opcode == spv::OpName && w.size() >= 3) names_[w[1]] = literal_string(w, 2);
      if (instruction.opcode == spv::OpDecorate && w.size() >= 4 && w[2] == spv::DecorationDescriptorSet) set_[w[1]] = w[3];
      if (instruction.opcode == spv::OpDecorate && w.size() >= 4 && w[2] == spv::DecorationBinding) binding_[w[1]] = w[3];
      if (instruction.opcode == spv::OpDecorate && w.size() >= 3 && w[2] == spv::DecorationNonUniform) nonuniform_.insert(w[1]);
      if (annotation(instruction.opcode) || instruction.non_semantic) continue;
      for (uint16_t word : instruction.uses) uses_[w[word]].push_back({i, word});
    }
  }

  const Instruction* defining(uint32_t id) const {
    auto found = definition_.find(id);
    return found == definition_.end() ? nullptr : &module_.instructions[found->second];
  }
  size_t position(uint32_t id) const { return definition_.at(id); }
  const std::vector<Use>& uses(uint32_t id) const {
    static const std::vector<Use> none;
    auto found = uses_.find(id);
    return found == uses_.end() ? none : found->second;
  }
  const Instruction& at(const Use& use) const { return module_.instructions[use.first]; }
  bool nonuniform(uint32_t id) const { return nonuniform_.count(id) != 0; }
  std::optional<std::pair<uint32_t, uint32_t>> slot(uint32_t variable) const {
    auto binding = binding_.find(variable);
    if (binding == binding_.end()) return std::nullopt;
    auto set = set_.find(variable);
    return std::make_pair(set == set_.end() ? 0u : set->second, binding->second);
  }
  // `'name'`, or the slot's words when the module names nothing.
  std::string quoted(uint32_t variable) const {
    auto name = names_.find(variable);
    if (name != names_.end() && !name->second.empty()) return "'" + name->second + "'";
    auto where = slot(variable);
    return where ? "the resource at set " + std::to_string(where->first) + " binding " + std::to_string(where->second)
                 : "a resource";
  }
  // The variable a loaded value comes from: the load's pointer, through one access chain.
  uint32_t source_variable(uint32_t loaded) const {
    const Instruction* load = defining(loaded);
    if (!load || load->opcode != spv::OpLoad || load->words.size() < 4) return 0;
    const Instruction* pointer = defining(load->words[3]);
    if (pointer && (pointer->opcode == spv::OpAccessChain || pointer->opcode == spv::OpInBoundsAccessChain) &&
        pointer->words.size() >= 4)
      return pointer->words[3];
    return load->words[3];
  }
  // The type an ID of a type names, through pointers and arrays: OpTypeImage, OpTypeSampler or something else.
  uint32_t innermost(uint32_t type, bool* array = nullptr) const {
    for (int depth = 0; depth < 8; ++depth) {
      const Instruction* t = defining(type);
      if (!t) return 0;
      if (t->opcode == spv::OpTypePointer && t->words.size() >= 4) {
        type = t->words[3];
      } else if ((t->opcode == spv::OpTypeArray || t->opcode == spv::OpTypeRuntimeArray) && t->words.size() >= 3) {
        if (array) *array = true;
        type = t->words[2];
      } else {
        return t->opcode;
      }
    }
    return 0;
  }

 private:
  static std::string literal_string(const std::vector<uint32_t>& w, size_t from) {
    std::string text;
    for (size_t i = from; i < w.size(); ++i)
      for (int byte = 0; byte < 4; ++byte) {
        const char c = static_cast<char>((w[i] >> (8 * byte)) & 0xff);
        if (c == '\0') return text;
        text.push_back(c);
      }
    return text;
  }

  const Module& module_;
  std::map<uint32_t, size_t> definition_;
  std::map<uint32_t, std::string> names_;
  std::map<uint32_t, uint32_t> set_, binding_;
  std::set<uint32_t> nonuniform_;
  std::map<uint32_t, std::vector<Use>> uses_;
};

struct Pair {
  uint32_t textures = 0;  // the texture array's variable
  uint32_t sampler = 0;   // the sampler's variable
  std::pair<uint32_t, uint32_t> slot;
};

bool is_access_chain(uint32_t opcode) { return opcode == spv::OpAccessChain || opcode == spv::OpInBoundsAccessChain; }

// The slots that hold exactly one texture and one sampler variable, at least one of them an array (a single
// texture with a single sampler is SPIRV-Tools' to combine).
Result<std::vector<Pair>> find_pairs(const Module& module, const Facts& facts) {
  struct Seen {
    std::vector<uint32_t> textures, samplers;
    bool array = false;
  };
  std::map<std::pair<uint32_t, uint32_t>, Seen> slots;
  for (const Instruction& instruction : module.instructions) {
    if (instruction.opcode != spv::OpVariable || instruction.words.size() < 4 ||
        instruction.words[3] != spv::StorageClassUniformConstant)
      continue;
    bool array = false;
    const uint32_t kind = facts.innermost(instruction.words[1], &array);
    if (kind != spv::OpTypeImage && kind != spv::OpTypeSampler) continue;
    auto slot = facts.slot(instruction.result);
    if (!slot) continue;
    Seen& seen = slots[*slot];
    (kind == spv::OpTypeImage ? seen.textures : seen.samplers).push_back(instruction.result);
    seen.array |= array;
  }
  std::vector<Pair> pairs;
  for (const auto& [slot, seen] : slots) {
    if (seen.textures.size() != 1 || seen.samplers.size() != 1 || !seen.array) continue;
    const uint32_t textures = seen.textures[0], sampler = seen.samplers[0];
    const Instruction* sampler_variable = facts.defining(sampler);
    bool sampler_array = false, textures_array = false;
    facts.innermost(sampler_variable->words[1], &sampler_array);
    facts.innermost(facts.defining(textures)->words[1], &textures_array);
    const std::string where = "set " + std::to_string(slot.first) + " binding " + std::to_string(slot.second);
    if (sampler_array)
      return failure(facts.quoted(sampler) + " : with combined image samplers, a texture (or a texture array) and one "
                     "sampler at a binding become one combined image sampler, but " + facts.quoted(sampler) + " at " +
                     where + " is an array of samplers, beside " + (textures_array ? "the texture array " : "the texture ") +
                     facts.quoted(textures) + ": declare one sampler at that register, or give the samplers their own "
                     "binding (an s shift)");
    pairs.push_back({textures, sampler, slot});
  }
  return pairs;
}

// The rewrite of one pair (see the header), or why it cannot be made.
Result<Module> combine_pair(const Module& module, const Pair& pair) {
  const Facts facts(module);
  const std::string where = "set " + std::to_string(pair.slot.first) + " binding " + std::to_string(pair.slot.second);
  const std::string textures_name = facts.quoted(pair.textures), sampler_name = facts.quoted(pair.sampler);
  // "'name' : with combined image samplers, ... become one array of combined image samplers, but " + why.
  auto refused = [&](const std::string& about, const std::string& why) {
    return failure(about + " : with combined image samplers, the texture array " + textures_name + " and the sampler " +
                   sampler_name + " at " + where + " become one array of combined image samplers, but " + why);
  };
  const std::string own_binding = "give " + sampler_name + " its own binding (an s shift)";

  // The types: pointer -> array (runtime or sized) -> image.
  const Instruction& variable = *facts.defining(pair.textures);
  const Instruction* pointer_type = facts.defining(variable.words[1]);
  const Instruction* array_type = pointer_type ? facts.defining(pointer_type->words[3]) : nullptr;
  if (!array_type || (array_type->opcode != spv::OpTypeArray && array_type->opcode != spv::OpTypeRuntimeArray) ||
      facts.innermost(array_type->words[2]) != spv::OpTypeImage || !facts.defining(array_type->words[2]) ||
      facts.defining(array_type->words[2])->opcode != spv::OpTypeImage)
    return refused(textures_name, textures_name + " is an array of arrays, and kiln combines one-dimensional texture "
                   "arrays only: " + own_binding);
  const uint32_t image_type = array_type->words[2];
  const bool runtime = array_type->opcode == spv::OpTypeRuntimeArray;
  const uint32_t length = runtime ? 0 : array_type->words[3];

  // Every use of the array takes one element, and every use of an element pointer loads it.
  std::vector<size_t> chains, loads;                 // instruction indices
  std::map<uint32_t, uint32_t> chain_of_load;        // loaded image -> its access chain
  for (const Use& use : facts.uses(pair.textures)) {
    const Instruction& chain = facts.at(use);
    if (!is_access_chain(chain.opcode) || use.second != 3 || chain.words.size() != 5)
      return refused(textures_name, textures_name + " is used whole (copied or passed on), not one element at a "
                     "time, which kiln cannot rewrite: " + own_binding);
    chains.push_back(use.first);
    for (const Use& load_use : facts.uses(chain.result)) {
      const Instruction& load = facts.at(load_use);
      if (load.opcode != spv::OpLoad || load_use.second != 3)
        return refused(textures_name, "an element of " + textures_name + " is used other than by loading it, which "
                       "kiln cannot rewrite: " + own_binding);
      loads.push_back(load_use.first);
      chain_of_load[load.result] = chain.result;
    }
  }

  // Each loaded element is sampled with this sampler only.
  std::vector<size_t> sampled;  // the OpSampledImage instructions to become loads
  for (size_t load : loads)
    for (const Use& use : facts.uses(module.instructions[load].result)) {
      const Instruction& user = facts.at(use);
      if (user.opcode != spv::OpSampledImage || use.second != 3) continue;  // kept, through OpImage
      if (facts.source_variable(user.words[4]) != pair.sampler)
        return refused(textures_name, textures_name + " is also sampled with " +
                       facts.quoted(facts.source_variable(user.words[4])) + ": sample it with " + sampler_name +
                       " only, or " + own_binding);
      sampled.push_back(use.first);
    }
  // And the sampler samples the array only.
  for (const Use& use : facts.uses(pair.sampler)) {
    const Instruction& load = facts.at(use);
    if (load.opcode != spv::OpLoad || use.second != 3)
      return refused(sampler_name, sampler_name + " is used other than to sample " + textures_name + ": " + own_binding);
    for (const Use& sample : facts.uses(load.result)) {
      const Instruction& user = facts.at(sample);
      const uint32_t image = user.opcode == spv::OpSampledImage && sample.second == 4 ? user.words[3] : 0;
      if (image && chain_of_load.count(image)) continue;
      std::string other = image ? facts.quoted(facts.source_variable(image)) : std::string();
      return refused(sampler_name, image ? sampler_name + " also samples " + other + ": sample " + other +
                                               " with another sampler, or " + own_binding
                                         : sampler_name + " is used other than to sample " + textures_name + ": " +
                                               own_binding);
    }
  }

  // The types the combined array needs, found or made, all placed before the variable (moved up when the module
  // declares them after it: each depends only on the image type and the array length, declared before the array).
  uint32_t bound = module.header[3];
  const size_t variable_at = facts.position(pair.textures);
  std::vector<Instruction> before_variable;
  std::set<size_t> moved;
  auto find_type = [&](auto matches) -> std::optional<size_t> {
    for (size_t i = 0; i < module.instructions.size(); ++i)
      if (matches(module.instructions[i])) return i;
    return std::nullopt;
  };
  auto place = [&](std::optional<size_t> found, spv::Op opcode, std::vector<uint32_t> operands, std::vector<uint16_t> uses) {
    if (found) {
      if (*found > variable_at) {
        before_variable.push_back(module.instructions[*found]);
        moved.insert(*found);
      }
      return module.instructions[*found].result;
    }
    const uint32_t id = bound++;
    operands.insert(operands.begin(), id);
    before_variable.push_back(make(opcode, std::move(operands), id, std::move(uses)));
    return id;
  };
  const uint32_t sampled_image_type = place(
      find_type([&](const Instruction& i) { return i.opcode == spv::OpTypeSampledImage && i.words[2] == image_type; }),
      spv::OpTypeSampledImage, {image_type}, {2});
  const uint32_t combined_array_type = place(find_type([&](const Instruction& i) {
    return runtime ? i.opcode == spv::OpTypeRuntimeArray && i.words[2] == sampled_image_type
                   : i.opcode == spv::OpTypeArray && i.words[2] == sampled_image_type && i.words[3] == length;
  }), runtime ? spv::OpTypeRuntimeArray : spv::OpTypeArray,
      runtime ? std::vector<uint32_t>{sampled_image_type} : std::vector<uint32_t>{sampled_image_type, length},
      runtime ? std::vector<uint16_t>{2} : std::vector<uint16_t>{2, 3});
  auto pointer_to = [&](uint32_t pointee) {
    return place(find_type([&](const Instruction& i) {
      return i.opcode == spv::OpTypePointer && i.words[2] == spv::StorageClassUniformConstant && i.words[3] == pointee;
    }), spv::OpTypePointer, {spv::StorageClassUniformConstant, pointee}, {3});
  };
  const uint32_t array_pointer = pointer_to(combined_array_type);
  const uint32_t element_pointer = pointer_to(sampled_image_type);

  // The instructions, rewritten.
  std::set<size_t> is_chain(chains.begin(), chains.end()), is_load(loads.begin(), loads.end()),
      is_sampled(sampled.begin(), sampled.end());
  std::vector<Instruction> decorations;  // NonUniform on the new loads, after the module's last annotation
  size_t last_annotation = 0;
  for (size_t i = 0; i < module.instructions.size(); ++i)
    if (annotation(module.instructions[i].opcode) && module.instructions[i].opcode != spv::OpName &&
        module.instructions[i].opcode != spv::OpMemberName && module.instructions[i].opcode != spv::OpEntryPoint)
      last_annotation = i;
  std::vector<Instruction> rewritten;
  for (size_t i = 0; i < module.instructions.size(); ++i) {
    if (moved.count(i)) continue;
    Instruction instruction = module.instructions[i];
    if (i == variable_at) {
      rewritten.insert(rewritten.end(), before_variable.begin(), before_variable.end());
      instruction.words[1] = array_pointer;
    } else if (is_chain.count(i)) {
      instruction.words[1] = element_pointer;
    } else if (is_load.count(i)) {
      // %element = OpLoad %image %chain  ->  %combined = OpLoad %sampled_image %chain; %element = OpImage %image %combined
      const uint32_t combined = bound++;
      Instruction load = instruction;
      load.words[1] = sampled_image_type;
      load.words[2] = combined;
      load.result = combined;
      if (facts.nonuniform(instruction.result))
        decorations.push_back(make(spv::OpDecorate, {combined, spv::DecorationNonUniform}, 0, {1}));
      rewritten.push_back(std::move(load));
      instruction = make(spv::OpImage, {image_type, instruction.result, combined}, instruction.result, {1, 3});
    } else if (is_sampled.count(i)) {
      // %sampled = OpSampledImage %type %element %sampler  ->  %sampled = OpLoad %sampled_image %chain
      const uint32_t element = instruction.words[3];
      if (facts.nonuniform(element) && !facts.nonuniform(instruction.result))
        decorations.push_back(make(spv::OpDecorate, {instruction.result, spv::DecorationNonUniform}, 0, {1}));
      instruction = make(spv::OpLoad, {sampled_image_type, instruction.result, chain_of_load.at(element)},
                         instruction.result, {1, 3});
    }
    rewritten.push_back(std::move(instruction));
  }
  // The new decorations go after the last annotation of the original module, which `rewritten` keeps at the
  // same index (nothing before the types section moved or grew).
  rewritten.insert(rewritten.begin() + static_cast<std::ptrdiff_t>(last_annotation + 1), decorations.begin(), decorations.end());
  Module out;
  out.header = module.header;
  out.header[3] = bound;
  out.instructions = std::move(rewritten);
  return out;
}

}  // namespace texture_arrays

Result<CombinedTextureArrays> combine_texture_arrays(const std::vector<uint32_t>& spirv) {
  using namespace texture_arrays;
  CombinedTextureArrays out;
  std::optional<Module> module = parse(spirv);
  if (!module) return failure("SPIRV-Tools cannot parse the module to combine its texture arrays");
  std::vector<Pair> pairs;
  {
    const Facts facts(*module);
    Result<std::vector<Pair>> found = find_pairs(*module, facts);
    if (!found) return failure(found.error());
    pairs = std::move(*found);
  }
  if (pairs.empty()) {
    out.spirv = spirv;
    return out;
  }
  for (const Pair& pair : pairs) {
    Result<Module> combined = combine_pair(*module, pair);
    if (!combined) return failure(combined.error());
    *module = std::move(*combined);
    out.slots.insert(pair.slot);
  }
  out.spirv = words_of(*module);
  return out;
}

}  // namespace kiln
