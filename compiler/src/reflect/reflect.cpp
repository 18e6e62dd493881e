#include "reflect/reflect.hpp"

#include <spirv_cross/spirv_cross.hpp>

#include <algorithm>
#include <map>
#include <set>

namespace kiln {
namespace {

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

std::vector<BlockMember> block_members(const spirv_cross::Compiler& compiler, const spirv_cross::SPIRType& type) {
  std::vector<BlockMember> members;
  for (uint32_t i = 0; i < type.member_types.size(); ++i) {
    const auto& member_type = compiler.get_type(type.member_types[i]);
    BlockMember& member = members.emplace_back();
    member.name = compiler.get_member_name(type.self, i);
    member.offset = compiler.type_struct_member_offset(type, i);
    member.size = declared_member_size(compiler, type, i);
    member.type = type_name(member_type);
    if (!member_type.array.empty()) member.array_stride = compiler.type_struct_member_array_stride(type, i);
  }
  return members;
}

}  // namespace

Reflection reflect_spirv(const std::vector<uint32_t>& spirv) {
  spirv_cross::Compiler compiler(spirv);
  spirv_cross::ShaderResources resources = compiler.get_shader_resources();
  Reflection out;
  auto add = [&](const spirv_cross::SmallVector<spirv_cross::Resource>& items, ResourceKind kind) {
    for (const auto& item : items) {
      const auto& type = compiler.get_type(item.type_id);
      const auto& base_type = compiler.get_type(item.base_type_id);
      Resource& resource = out.resources.emplace_back();
      resource.name = compiler.get_name(item.id);
      if (resource.name.empty()) resource.name = item.name;
      resource.kind = kind;
      resource.set = compiler.get_decoration(item.id, spv::DecorationDescriptorSet);
      resource.binding = compiler.get_decoration(item.id, spv::DecorationBinding);
      resource.count = type.array.empty() ? 1u : type.array[0];
      if (is_block(kind)) {
        resource.size = checked_block_size(compiler, base_type, resource.name);
        resource.members = block_members(compiler, base_type);
      } else if (is_image(kind)) {
        resource.dimension = image_dimension(base_type);
        resource.depth = base_type.image.depth;
      }
    }
  };
  add(resources.uniform_buffers, ResourceKind::UniformBuffer);
  add(resources.storage_buffers, ResourceKind::StorageBuffer);
  add(resources.separate_images, ResourceKind::Texture);
  add(resources.separate_samplers, ResourceKind::Sampler);
  add(resources.sampled_images, ResourceKind::CombinedImageSampler);
  add(resources.storage_images, ResourceKind::StorageImage);
  std::sort(out.resources.begin(), out.resources.end(), [](const Resource& a, const Resource& b) {
    return std::tie(a.set, a.binding, a.name) < std::tie(b.set, b.binding, b.name);
  });

  for (const auto& item : resources.push_constant_buffers) {
    const auto& type = compiler.get_type(item.base_type_id);
    PushConstantBlock& block = out.push_constants.emplace_back();
    block.name = compiler.get_name(item.id);
    block.size = checked_block_size(compiler, type, block.name);
    block.members = block_members(compiler, type);
  }

  auto interface = [&](const spirv_cross::SmallVector<spirv_cross::Resource>& items) {
    std::vector<StageVariable> variables;
    for (const auto& item : items)
      variables.push_back({compiler.get_name(item.id), compiler.get_decoration(item.id, spv::DecorationLocation),
                           type_name(compiler.get_type(item.type_id))});
    std::sort(variables.begin(), variables.end(),
                     [](const StageVariable& a, const StageVariable& b) { return a.location < b.location; });
    return variables;
  };
  out.inputs = interface(resources.stage_inputs);
  out.outputs = interface(resources.stage_outputs);
  if (compiler.get_execution_model() == spv::ExecutionModelGLCompute)
    out.local_size = std::array<uint32_t, 3>{compiler.get_execution_mode_argument(spv::ExecutionModeLocalSize, 0),
                                             compiler.get_execution_mode_argument(spv::ExecutionModeLocalSize, 1),
                                             compiler.get_execution_mode_argument(spv::ExecutionModeLocalSize, 2)};
  return out;
}

MergedLayout merge_layouts(const std::vector<const Reflection*>& reflections) {
  MergedLayout out;
  std::map<std::pair<uint32_t, uint32_t>, const Resource*> by_slot;  // (set, binding) -> first resource seen there
  std::map<std::string, const Resource*> by_name;
  const std::vector<PushConstantBlock>* push_constants = nullptr;
  std::set<std::pair<std::string, std::string>> reported;
  auto clash = [&](LayoutClash::Kind kind, const Resource& first, const Resource& second) {
    if (reported.emplace(nlohmann::json(first).dump(), nlohmann::json(second).dump()).second)
      out.clashes.push_back({kind, first, second});
  };
  for (const Reflection* reflection : reflections) {
    for (const Resource& resource : reflection->resources) {
      auto [at_slot, new_slot] = by_slot.emplace(std::make_pair(resource.set, resource.binding), &resource);
      if (!new_slot && *at_slot->second != resource) clash(LayoutClash::Kind::SharedSlot, *at_slot->second, resource);
      auto [named, new_name] = by_name.emplace(resource.name, &resource);
      if (!new_name && (named->second->set != resource.set || named->second->binding != resource.binding))
        clash(LayoutClash::Kind::MovedResource, *named->second, resource);
    }
    const std::vector<PushConstantBlock>& push = reflection->push_constants;
    if (push.empty()) continue;
    if (!push_constants) push_constants = &push;
    else if (push != *push_constants && reported.emplace("push constants", "").second)
      out.clashes.push_back({LayoutClash::Kind::PushConstants, {}, {}});
  }
  for (const auto& [slot, resource] : by_slot) out.layout.resources.push_back(*resource);
  if (push_constants) out.layout.push_constants = *push_constants;
  return out;
}

}  // namespace kiln
