// SPDX-License-Identifier: Apache-2.0
#include "frontend/dxc_semantics.hpp"

#include <glslang/SPIRV/spirv.hpp>

#include <algorithm>
#include <cctype>
#include <map>
#include <optional>
#include <regex>
#include <set>
#include <tuple>

#include "frontend/hlsl_compat.hpp"
#include "frontend/spirv_module.hpp"

namespace kiln {
namespace {

using spirv_edit::Instruction;
using spirv_edit::make;

std::string upper(std::string_view text) {
  std::string out(text);
  for (char& c : out) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return out;
}

// glslang's hlsl_functionality1 decorations, which kiln removes again (they would add an extension to every module).
constexpr uint32_t kDecorationUserSemantic = 5635, kDecorationUserType = 5636, kDecorationCounterBuffer = 5634;

}  // namespace

std::vector<std::string> unbounded_resource_arrays(std::string_view text) {
  // A resource type (with its template argument), a name, `[` `]`; at brace depth 0.
  static const std::regex declaration(
      R"(\b(?:RW|RasterizerOrdered)?(?:Texture(?:1D|2D|3D|Cube)(?:Array|MS|MSArray)?|Buffer|StructuredBuffer|ByteAddressBuffer)"
      R"(|SamplerState|SamplerComparisonState|ConstantBuffer|AppendStructuredBuffer|ConsumeStructuredBuffer)"
      R"(|SubpassInput(?:MS)?)[ \t]{0,64}(?:<[^;{}()]{0,256}>)?\s{1,64}([A-Za-z_]\w{0,255})[ \t]{0,64}\[[ \t]{0,64}\])");
  std::vector<std::string> names;
  // Every match holds `[`, at most 64 blanks, `]`. Most sources have none, and std::regex over a whole preprocessed
  // library was 2% of a compile job.
  bool empty_brackets = false;
  for (size_t at = text.find('['); at != std::string_view::npos && !empty_brackets; at = text.find('[', at + 1)) {
    const size_t close = text.find_first_not_of(" \t", at + 1);
    empty_brackets = close != std::string_view::npos && close - at - 1 <= 64 && text[close] == ']';
  }
  if (!empty_brackets) return names;
  const std::string source(text);
  for (const std::smatch& match : file_scope_matches(source, declaration)) names.push_back(match[1]);
  return names;
}

bool names_builtin_semantics(std::string_view text) {
  const std::string up = upper(text);
  return up.find("SV_VIEWID") != std::string::npos || up.find("SV_SHADINGRATE") != std::string::npos;
}

std::vector<std::pair<std::string, uint32_t>> explicit_locations(std::string_view text) {
  std::vector<std::pair<std::string, uint32_t>> found;
  auto word = [&](size_t at) {
    size_t end = at;
    while (end < text.size() && (std::isalnum(static_cast<unsigned char>(text[end])) || text[end] == '_')) ++end;
    return end;
  };
  auto blanks = [&](size_t at) {
    while (at < text.size() && std::isspace(static_cast<unsigned char>(text[at]))) ++at;
    return at;
  };
  for (size_t at = text.find("location"); at != std::string_view::npos; at = text.find("location", at + 8)) {
    // `vk :: location ( N ) ]]`, as the preprocessor spaces it or not.
    size_t colons = at;
    while (colons > 0 && std::isspace(static_cast<unsigned char>(text[colons - 1]))) --colons;
    if (colons < 2 || text.substr(colons - 2, 2) != "::" || word(at) != at + 8) continue;
    size_t vk = colons - 2;
    while (vk > 0 && std::isspace(static_cast<unsigned char>(text[vk - 1]))) --vk;
    if (vk < 2 || text.substr(vk - 2, 2) != "vk" || (vk > 2 && word(vk - 3) != vk - 3)) continue;
    size_t cursor = blanks(at + 8);
    if (cursor >= text.size() || text[cursor] != '(') continue;
    const size_t digits = blanks(cursor + 1), digits_end = word(digits);
    if (digits_end == digits || digits_end - digits > 9 ||
        !std::all_of(text.begin() + digits, text.begin() + digits_end, [](char c) { return std::isdigit(static_cast<unsigned char>(c)); }))
      continue;
    const uint32_t location = static_cast<uint32_t>(std::stoul(std::string(text.substr(digits, digits_end - digits))));
    cursor = blanks(digits_end);
    if (cursor >= text.size() || text[cursor] != ')') continue;
    cursor = blanks(cursor + 1);
    if (text.substr(cursor, 2) != "]]") continue;
    ++cursor;
    // The declared name: the last word before the declaration's semantic, its end or the next parameter, past
    // other attribute groups, qualifiers, the type's template arguments and array sizes (bounded: a declaration is
    // short, and a malformed one must not make this scan the rest of the file).
    std::string name;
    int depth = 0;
    for (size_t scanned = 0; ++cursor < text.size() && scanned < 4096; ++scanned) {
      const char c = text[cursor];
      if (c == '[' || c == '<' || c == '(') ++depth;
      if (c == ']' || c == '>' || c == ')') --depth;
      if (depth < 0 || (depth == 0 && (c == ':' || c == ';' || c == ',' || c == '=' || c == '{' || c == '}'))) break;
      if (depth == 0 && (std::isalpha(static_cast<unsigned char>(c)) || c == '_') && !std::isalnum(static_cast<unsigned char>(text[cursor - 1])) &&
          text[cursor - 1] != '_') {
        const size_t end = word(cursor);
        name = std::string(text.substr(cursor, end - cursor));
        cursor = end - 1;
      }
    }
    if (!name.empty()) found.emplace_back(std::move(name), location);
  }
  std::sort(found.begin(), found.end());
  found.erase(std::unique(found.begin(), found.end()), found.end());
  return found;
}

Result<void> make_arrays_unbounded(std::vector<uint32_t>& spirv, const std::vector<std::string>& names) {
  if (names.empty()) return {};
  std::optional<spirv_edit::Module> parsed = spirv_edit::Module::parse(spirv);
  if (!parsed) return failure("glslang's module does not parse");
  spirv_edit::Module& module = *parsed;
  const std::set<std::string> wanted(names.begin(), names.end());
  bool changed = false;
  for (bool again = true; again;) {  // each edit inserts instructions: look again from the start
    again = false;
    const std::map<uint32_t, size_t> definition = module.definitions();
    auto defining = [&](uint32_t id) -> const Instruction* {
      auto it = definition.find(id);
      return it == definition.end() ? nullptr : &module.instructions()[it->second];
    };
    // The variables some function uses: an unused one (glslang keeps every declaration) is left alone, or its
    // capability would stay after the optimizer removes it, and every target would have to express it.
    std::set<uint32_t> used;
    bool in_function = false;
    for (const Instruction& in : module.instructions()) {
      if (in.op() == spv::OpFunction) in_function = true;
      if (in_function)
        for (size_t w = 1; w < in.words.size(); ++w) used.insert(in.words[w]);
    }
    for (size_t i = 0; i < module.instructions().size() && !again; ++i) {
      const Instruction& variable = module.instructions()[i];
      if (variable.op() != spv::OpVariable || !used.count(variable.words[2]) || !wanted.count(module.name_of(variable.words[2])))
        continue;
      const Instruction* pointer = defining(variable.words[1]);
      const Instruction* array = pointer && pointer->op() == spv::OpTypePointer ? defining(pointer->words[3]) : nullptr;
      if (!array || array->op() != spv::OpTypeArray) continue;  // already a runtime array, or not an array
      const uint32_t storage = pointer->words[2], element = array->words[2], variable_id = variable.words[2];
      const uint32_t runtime = module.new_id(), runtime_pointer = module.new_id();
      module.add_declaration(make(spv::OpTypeRuntimeArray, {runtime, element}));
      module.add_declaration(make(spv::OpTypePointer, {runtime_pointer, storage, runtime}));
      // The variable must follow its new type: move it after the declarations just added.
      auto& code = module.instructions();
      auto at = std::find_if(code.begin(), code.end(), [&](const Instruction& in) {
        return in.op() == spv::OpVariable && in.words[2] == variable_id;
      });
      Instruction moved = *at;
      moved.words[1] = runtime_pointer;
      code.erase(at);
      module.add_declaration(std::move(moved));
      changed = again = true;
    }
  }
  if (changed) {
    module.add_capability(spv::CapabilityRuntimeDescriptorArray);
    if (module.version() < 0x00010500u) module.add_extension("SPV_EXT_descriptor_indexing");
    spirv = module.words();
  }
  return {};
}

Result<void> restore_builtin_semantics(std::vector<uint32_t>& spirv, const std::vector<std::pair<std::string, uint32_t>>& located) {
  std::optional<spirv_edit::Module> parsed = spirv_edit::Module::parse(spirv);
  if (!parsed) return failure("glslang's module does not parse");
  spirv_edit::Module& module = *parsed;
  std::vector<Instruction>& code = module.instructions();
  std::map<uint32_t, uint32_t> storage_classes;  // variable -> its storage class (by id: the edits below move instructions)
  for (const Instruction& in : code)
    if (in.op() == spv::OpVariable && in.words.size() > 3) storage_classes[in.words[2]] = in.words[3];
  auto storage_of = [&](uint32_t id) -> uint32_t {
    auto it = storage_classes.find(id);
    return it == storage_classes.end() ? ~0u : it->second;
  };
  // The variables whose semantic is a built-in DXC knows and glslang 12 does not: id -> the built-in.
  std::map<uint32_t, uint32_t> builtins;
  for (const Instruction& in : code)
    if (in.op() == spv::OpDecorateString && in.words.size() > 3 && in.words[2] == kDecorationUserSemantic) {
      const std::string semantic = upper(in.string_at(3));
      const uint32_t storage = storage_of(in.words[1]);
      if (semantic == "SV_VIEWID" && storage == spv::StorageClassInput) builtins[in.words[1]] = spv::BuiltInViewIndex;
      if (semantic == "SV_SHADINGRATE" && storage == spv::StorageClassInput) builtins[in.words[1]] = spv::BuiltInShadingRateKHR;
      if (semantic == "SV_SHADINGRATE" && storage == spv::StorageClassOutput) builtins[in.words[1]] = spv::BuiltInPrimitiveShadingRateKHR;
    }
  // Their locations go, and the user variables after them move down, as if glslang had known them.
  std::map<uint32_t, std::vector<uint32_t>> freed;  // storage class -> the locations the built-ins held
  for (const Instruction& in : code)
    if (in.op() == spv::OpDecorate && in.words.size() > 3 && in.words[2] == spv::DecorationLocation && builtins.count(in.words[1]))
      freed[storage_of(in.words[1])].push_back(in.words[3]);
  std::erase_if(code, [&](const Instruction& in) {
    const uint32_t op = in.op();
    if ((op == spv::OpDecorateString || op == spv::OpMemberDecorateString || op == spv::OpDecorateId) && in.words.size() > 2) {
      const uint32_t decoration = in.words[op == spv::OpMemberDecorateString ? 3 : 2];
      if (decoration == kDecorationUserSemantic || decoration == kDecorationUserType || decoration == kDecorationCounterBuffer) return true;
    }
    if (op == spv::OpExtension && (in.string_at(1) == "SPV_GOOGLE_hlsl_functionality1" || in.string_at(1) == "SPV_GOOGLE_user_type"))
      return true;
    return op == spv::OpDecorate && in.words.size() > 2 && in.words[2] == spv::DecorationLocation && builtins.count(in.words[1]);
  });
  // A location the source states (`[[vk::location(N)]]`, by its declaration's name: glslang names a struct member's
  // variable "input.member") stays where it is: only glslang's automatic numbering counted the built-ins.
  auto stated = [&](uint32_t id, uint32_t location) {
    const std::string name = module.name_of(id);
    const std::string member = name.substr(name.rfind('.') == std::string::npos ? 0 : name.rfind('.') + 1);
    return std::binary_search(located.begin(), located.end(), std::make_pair(member, location));
  };
  for (Instruction& in : code)
    if (in.op() == spv::OpDecorate && in.words.size() > 3 && in.words[2] == spv::DecorationLocation) {
      const auto it = freed.find(storage_of(in.words[1]));
      if (it == freed.end()) continue;
      const uint32_t location = in.words[3];
      if (stated(in.words[1], location)) continue;
      in.words[3] -= static_cast<uint32_t>(std::count_if(it->second.begin(), it->second.end(), [&](uint32_t l) { return l < location; }));
    }
  bool view = false, shading_rate = false;
  for (const auto& [id, builtin] : builtins) {
    module.add_annotation(make(spv::OpDecorate, {id, spv::DecorationBuiltIn, builtin}));
    view = view || builtin == spv::BuiltInViewIndex;
    shading_rate = shading_rate || builtin != spv::BuiltInViewIndex;
  }
  if (view) {
    module.add_capability(spv::CapabilityMultiView);
    if (module.version() < 0x00010300u) module.add_extension("SPV_KHR_multiview");
  }
  if (shading_rate) {
    module.add_capability(spv::CapabilityFragmentShadingRateKHR);
    module.add_extension("SPV_KHR_fragment_shading_rate");
  }
  spirv = module.words();
  return {};
}

std::optional<std::string> conflicting_location(const std::vector<uint32_t>& spirv) {
  std::optional<spirv_edit::Module> parsed = spirv_edit::Module::parse(spirv);
  if (!parsed) return std::nullopt;
  std::map<uint32_t, uint32_t> location, component;
  std::map<uint32_t, uint32_t> storage;  // variable -> storage class
  std::set<uint32_t> interface;
  for (const Instruction& in : parsed->instructions()) {
    if (in.op() == spv::OpDecorate && in.words.size() > 3 && in.words[2] == spv::DecorationLocation) location[in.words[1]] = in.words[3];
    if (in.op() == spv::OpDecorate && in.words.size() > 3 && in.words[2] == spv::DecorationComponent) component[in.words[1]] = in.words[3];
    if (in.op() == spv::OpVariable && in.words.size() > 3) storage[in.words[2]] = in.words[3];
    if (in.op() == spv::OpEntryPoint && in.words.size() > 3) {
      size_t at = 3;
      while (at < in.words.size() && (in.words[at] & 0xff000000u) != 0 && (in.words[at] & 0xff) && (in.words[at] >> 8 & 0xff) &&
             (in.words[at] >> 16 & 0xff))
        ++at;  // the name's words: every byte set, until the one holding its terminating zero
      for (++at; at < in.words.size(); ++at) interface.insert(in.words[at]);
    }
  }
  std::set<std::tuple<uint32_t, uint32_t, uint32_t>> taken;  // storage class, location, component
  for (uint32_t id : interface) {
    if (!location.count(id) || !storage.count(id)) continue;
    const uint32_t kind = storage[id];
    if (kind != spv::StorageClassInput && kind != spv::StorageClassOutput) continue;
    const uint32_t comp = component.count(id) ? component[id] : 0;
    if (!taken.insert({kind, location[id], comp}).second)
      return std::string("conflicting ") + (kind == spv::StorageClassInput ? "input" : "output") +
             " location assignment at location " + std::to_string(location[id]);
  }
  return std::nullopt;
}

void restore_reserved_names(std::vector<uint32_t>& spirv) {
  std::optional<spirv_edit::Module> parsed = spirv_edit::Module::parse(spirv);
  if (!parsed) return;
  bool changed = false;
  for (Instruction& in : parsed->instructions()) {
    const size_t at = in.op() == spv::OpName ? 2 : in.op() == spv::OpMemberName ? 3 : 0;
    if (at == 0 || in.words.size() <= at) continue;
    const std::string name = in.string_at(at);
    if (!name.starts_with(kReservedNamePrefix)) continue;
    in = spirv_edit::make_with_string(in.op(), std::vector<uint32_t>(in.words.begin() + 1, in.words.begin() + static_cast<long>(at)),
                          std::string_view(name).substr(kReservedNamePrefix.size()));
    changed = true;
  }
  if (changed) spirv = parsed->words();
}

namespace {

// Whether a member of type `type` may start at `offset` in a block (Vulkan's relaxed block layout, which glslang's
// HLSL layouts follow): scalars and vectors at a multiple of their component's size, a vector not across a 16-byte
// boundary, matrices, arrays and structs at a multiple of 16.
bool fits_at(const std::map<uint32_t, size_t>& definition, const std::vector<Instruction>& instructions, uint32_t type, uint32_t offset) {
  auto defining = [&](uint32_t id) -> const Instruction* {
    auto it = definition.find(id);
    return it == definition.end() ? nullptr : &instructions[it->second];
  };
  const Instruction* in = defining(type);
  if (!in) return false;
  if (in->op() == spv::OpTypeInt || in->op() == spv::OpTypeFloat) return in->words.size() > 2 && offset % (in->words[2] / 8) == 0;
  if (in->op() == spv::OpTypeVector && in->words.size() > 3) {
    const Instruction* component = defining(in->words[2]);
    if (!component || component->words.size() < 3) return false;
    const uint32_t size = component->words[2] / 8, bytes = size * in->words[3];
    return offset % size == 0 && (bytes > 16 || offset % 16 + bytes <= 16);
  }
  return offset % 16 == 0;
}

}  // namespace

std::vector<UnhonouredOffset> write_member_offsets(std::vector<uint32_t>& spirv, const std::vector<StatedOffset>& stated) {
  std::vector<UnhonouredOffset> unhonoured;
  if (stated.empty()) return unhonoured;
  std::optional<spirv_edit::Module> parsed = spirv_edit::Module::parse(spirv);
  if (!parsed) {
    for (size_t i = 0; i < stated.size(); ++i) unhonoured.push_back({i, "glslang's module does not parse"});
    return unhonoured;
  }
  spirv_edit::Module& module = *parsed;
  std::vector<Instruction>& instructions = module.instructions();
  std::set<uint32_t> array_elements;
  std::map<uint32_t, std::map<uint32_t, std::string>> member_names;  // struct -> member index -> name
  std::map<uint32_t, std::map<uint32_t, size_t>> offsets;            // struct -> member index -> its decoration
  for (size_t i = 0; i < instructions.size(); ++i) {
    const Instruction& in = instructions[i];
    if ((in.op() == spv::OpTypeArray || in.op() == spv::OpTypeRuntimeArray) && in.words.size() > 2) array_elements.insert(in.words[2]);
    if (in.op() == spv::OpMemberName && in.words.size() > 3) member_names[in.words[1]][in.words[2]] = in.string_at(3);
    if (in.op() == spv::OpMemberDecorate && in.words.size() > 4 && in.words[3] == spv::DecorationOffset) offsets[in.words[1]][in.words[2]] = i;
  }
  const std::map<uint32_t, size_t> definition = module.definitions();
  // Whether member `index` of `type` can start at `wanted` and those after it (not yet moved) move by `delta`.
  auto can_move = [&](uint32_t type, uint32_t index, uint32_t wanted, int64_t delta) {
    const Instruction& structure = instructions[definition.at(type)];
    for (auto it = offsets[type].find(index); it != offsets[type].end(); ++it) {
      const int64_t moved = it->first == index ? wanted : static_cast<int64_t>(instructions[it->second].words[4]) + delta;
      if (it->first + 2 >= structure.words.size() || moved < 0 ||
          !fits_at(definition, instructions, structure.words[it->first + 2], static_cast<uint32_t>(moved)))
        return false;
    }
    return true;
  };
  std::vector<bool> honoured(stated.size(), false);
  std::vector<std::string> reasons(stated.size());
  bool changed = false;
  for (auto& [type, members] : offsets) {
    std::vector<std::string> names;
    for (const auto& [index, name] : member_names[type]) names.push_back(name);
    auto matches = [&](const StatedOffset& offset) { return offset.record == module.name_of(type) || offset.members == names; };
    int32_t delta = 0;
    for (auto& [index, decoration] : members) {
      uint32_t& offset = instructions[decoration].words[4];
      offset = static_cast<uint32_t>(static_cast<int64_t>(offset) + delta);
      const std::string& member = member_names[type][index];
      for (size_t s = 0; s < stated.size(); ++s) {
        if (!matches(stated[s]) || stated[s].member != member) continue;
        const uint32_t wanted = stated[s].offset;
        if (wanted == offset) {
          honoured[s] = true;
          continue;
        }
        if (wanted < offset) {
          reasons[s] = "HLSL's packing puts it at " + std::to_string(offset) + ", after the members before it";
        } else if (!can_move(type, index, wanted, delta + static_cast<int64_t>(wanted) - offset)) {
          reasons[s] = "HLSL's packing puts it at " + std::to_string(offset) + ", and " + std::to_string(wanted - offset) +
                       " bytes later it, or a member after it, would break its alignment";
        } else if (array_elements.count(type)) {
          reasons[s] = "HLSL's packing puts it at " + std::to_string(offset) + ", and '" + stated[s].record +
                       "' is an array element, whose stride kiln does not change";
        } else {
          delta += static_cast<int32_t>(wanted - offset);
          offset = wanted;
          honoured[s] = true;
          changed = true;
        }
      }
    }
  }
  for (size_t s = 0; s < stated.size(); ++s)
    if (!honoured[s] && !reasons[s].empty()) unhonoured.push_back({s, reasons[s]});
  if (changed && unhonoured.empty()) spirv = module.words();
  return unhonoured;
}

}  // namespace kiln
