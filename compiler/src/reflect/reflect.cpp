#include "reflect/reflect.hpp"

#include <spirv_cross/spirv_cross.hpp>

#include <algorithm>
#include <map>
#include <set>

namespace kiln {
namespace {

using nlohmann::json;

std::string type_name(const spirv_cross::SPIRType& type) {
  std::string base;
  switch (type.basetype) {
    case spirv_cross::SPIRType::Float: base = "float"; break;
    case spirv_cross::SPIRType::Half: base = "float16_t"; break;
    case spirv_cross::SPIRType::Double: base = "double"; break;
    case spirv_cross::SPIRType::Int: base = "int"; break;
    case spirv_cross::SPIRType::UInt: base = "uint"; break;
    case spirv_cross::SPIRType::Short: base = "int16_t"; break;
    case spirv_cross::SPIRType::UShort: base = "uint16_t"; break;
    case spirv_cross::SPIRType::Boolean: base = "bool"; break;
    case spirv_cross::SPIRType::Struct: base = "struct"; break;
    case spirv_cross::SPIRType::Image: base = "texture"; break;
    case spirv_cross::SPIRType::SampledImage: base = "sampled_texture"; break;
    case spirv_cross::SPIRType::Sampler: base = "sampler"; break;
    default: base = "other"; break;
  }
  if (type.columns > 1) base += std::to_string(type.columns) + "x" + std::to_string(type.vecsize);
  else if (type.vecsize > 1) base += std::to_string(type.vecsize);
  for (uint32_t size : type.array) base += "[" + std::to_string(size) + "]";
  return base;
}

std::string image_dimension(const spirv_cross::SPIRType& type) {
  switch (type.image.dim) {
    case spv::Dim1D: return "1D";
    case spv::Dim2D: return type.image.arrayed ? "2DArray" : "2D";
    case spv::Dim3D: return "3D";
    case spv::DimCube: return type.image.arrayed ? "CubeArray" : "Cube";
    case spv::DimBuffer: return "Buffer";
    default: return "other";
  }
}

uint64_t declared_struct_size(const spirv_cross::Compiler& compiler, const spirv_cross::SPIRType& type);

// SPIRV-Cross multiplies array sizes by strides in 32 bits: `float4 a[268435456]` (4 GiB) came out as 0.
// Sizes are computed here in 64 bits instead, the way SPIRV-Cross defines them.
uint64_t declared_member_size(const spirv_cross::Compiler& compiler, const spirv_cross::SPIRType& type, uint32_t index) {
  const auto& member_type = compiler.get_type(type.member_types[index]);
  if (!member_type.array.empty()) {
    if (!member_type.array_size_literal.back()) return compiler.get_declared_struct_member_size(type, index);
    return uint64_t{member_type.array.back()} * compiler.type_struct_member_array_stride(type, index);
  }
  if (member_type.basetype == spirv_cross::SPIRType::Struct) return declared_struct_size(compiler, member_type);
  return compiler.get_declared_struct_member_size(type, index);
}

// The end of the last member (a runtime array counts 0, as in SPIRV-Cross).
uint64_t declared_struct_size(const spirv_cross::Compiler& compiler, const spirv_cross::SPIRType& type) {
  uint64_t size = 0;
  for (uint32_t i = 0; i < type.member_types.size(); ++i)
    size = std::max(size, uint64_t{compiler.type_struct_member_offset(type, i)} + declared_member_size(compiler, type, i));
  return size;
}

// SPIR-V member offsets are 32-bit: past 4 GiB a block's layout cannot be expressed, so the module's
// offsets have wrapped and no reflection of it would be true.
uint64_t checked_block_size(const spirv_cross::Compiler& compiler, const spirv_cross::SPIRType& type, const std::string& name) {
  const uint64_t size = declared_struct_size(compiler, type);
  if (size > UINT32_MAX)
    throw ReflectionError("buffer block '" + name + "' is " + std::to_string(size) +
                          " bytes; a block must be under 4 GiB (SPIR-V offsets are 32-bit)");
  return size;
}

json block_members(const spirv_cross::Compiler& compiler, const spirv_cross::SPIRType& type) {
  json members = json::array();
  for (uint32_t i = 0; i < type.member_types.size(); ++i) {
    const auto& member_type = compiler.get_type(type.member_types[i]);
    json member{{"name", compiler.get_member_name(type.self, i)},
                {"offset", compiler.type_struct_member_offset(type, i)},
                {"size", declared_member_size(compiler, type, i)},
                {"type", type_name(member_type)}};
    if (!member_type.array.empty()) member["array_stride"] = compiler.type_struct_member_array_stride(type, i);
    members.push_back(member);
  }
  return members;
}

}  // namespace

json reflect_spirv(const std::vector<uint32_t>& spirv) {
  spirv_cross::Compiler compiler(spirv);
  spirv_cross::ShaderResources resources = compiler.get_shader_resources();
  json out = json::object();
  json list = json::array();
  auto add = [&](const spirv_cross::SmallVector<spirv_cross::Resource>& items, const char* kind, bool block) {
    for (const auto& resource : items) {
      const auto& type = compiler.get_type(resource.type_id);
      const auto& base_type = compiler.get_type(resource.base_type_id);
      std::string name = compiler.get_name(resource.id);
      if (name.empty()) name = resource.name;
      json entry{{"name", name},
                 {"kind", kind},
                 {"set", compiler.get_decoration(resource.id, spv::DecorationDescriptorSet)},
                 {"binding", compiler.get_decoration(resource.id, spv::DecorationBinding)},
                 {"count", type.array.empty() ? 1u : type.array[0]}};
      if (block) {
        entry["size"] = checked_block_size(compiler, base_type, name);
        entry["members"] = block_members(compiler, base_type);
      } else if (base_type.basetype == spirv_cross::SPIRType::Image ||
                 base_type.basetype == spirv_cross::SPIRType::SampledImage) {
        entry["dimension"] = image_dimension(base_type);
        if (base_type.image.depth) entry["depth"] = true;
      }
      list.push_back(entry);
    }
  };
  add(resources.uniform_buffers, "uniform_buffer", true);
  add(resources.storage_buffers, "storage_buffer", true);
  add(resources.separate_images, "texture", false);
  add(resources.separate_samplers, "sampler", false);
  add(resources.sampled_images, "combined_image_sampler", false);
  add(resources.storage_images, "storage_image", false);
  std::sort(list.begin(), list.end(), [](const json& a, const json& b) {
    return std::tie(a["set"], a["binding"], a["name"]) < std::tie(b["set"], b["binding"], b["name"]);
  });
  out["resources"] = list;

  json push = json::array();
  for (const auto& resource : resources.push_constant_buffers) {
    const auto& type = compiler.get_type(resource.base_type_id);
    push.push_back({{"name", compiler.get_name(resource.id)},
                    {"size", checked_block_size(compiler, type, compiler.get_name(resource.id))},
                    {"members", block_members(compiler, type)}});
  }
  out["push_constants"] = push;

  auto interface = [&](const spirv_cross::SmallVector<spirv_cross::Resource>& items) {
    json vars = json::array();
    for (const auto& resource : items) {
      vars.push_back({{"name", compiler.get_name(resource.id)},
                      {"location", compiler.get_decoration(resource.id, spv::DecorationLocation)},
                      {"type", type_name(compiler.get_type(resource.type_id))}});
    }
    std::sort(vars.begin(), vars.end(), [](const json& a, const json& b) { return a["location"] < b["location"]; });
    return vars;
  };
  out["inputs"] = interface(resources.stage_inputs);
  out["outputs"] = interface(resources.stage_outputs);
  return out;
}

MergedLayout merge_layouts(const std::vector<const json*>& reflections) {
  MergedLayout out;
  std::map<std::pair<uint32_t, uint32_t>, json> by_slot;  // (set, binding) -> first resource seen there
  std::map<std::string, json> by_name;
  json push_constants = json::array();
  std::set<std::pair<std::string, std::string>> reported;
  auto clash = [&](LayoutClash::Kind kind, const json& first, const json& second) {
    if (reported.emplace(first.dump(), second.dump()).second) out.clashes.push_back({kind, first, second});
  };
  for (const json* reflection : reflections) {
    for (const json& resource : (*reflection)["resources"]) {
      auto slot = std::make_pair(resource["set"].get<uint32_t>(), resource["binding"].get<uint32_t>());
      auto [at_slot, new_slot] = by_slot.emplace(slot, resource);
      if (!new_slot && at_slot->second != resource) clash(LayoutClash::Kind::SharedSlot, at_slot->second, resource);
      auto [named, new_name] = by_name.emplace(resource["name"].get<std::string>(), resource);
      if (!new_name && (named->second["set"] != resource["set"] || named->second["binding"] != resource["binding"]))
        clash(LayoutClash::Kind::MovedResource, named->second, resource);
    }
    const json& push = (*reflection)["push_constants"];
    if (push.empty()) continue;
    if (push_constants.empty()) push_constants = push;
    else if (push != push_constants) clash(LayoutClash::Kind::PushConstants, push_constants, push);
  }
  json resources = json::array();
  for (auto& [slot, resource] : by_slot) resources.push_back(resource);
  out.layout = {{"resources", resources}, {"push_constants", push_constants}};
  return out;
}

bool holds_resource(const json& reflection, const json& resource) {
  for (const json& r : reflection["resources"])
    if (r == resource) return true;
  return false;
}

}  // namespace kiln
