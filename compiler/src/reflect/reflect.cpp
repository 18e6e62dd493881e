// SPDX-License-Identifier: Apache-2.0
#include "reflect/reflect.hpp"

#include <spirv_cross/spirv_cross.hpp>

#include <algorithm>
#include <map>
#include <optional>
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
      // A texel buffer is an image of dimension Buffer in SPIR-V, and its own descriptor type in Vulkan.
      resource.kind = base_type.image.dim != spv::DimBuffer ? kind
                      : kind == ResourceKind::Texture      ? ResourceKind::UniformTexelBuffer
                      : kind == ResourceKind::StorageImage ? ResourceKind::StorageTexelBuffer
                                                           : kind;
      resource.set = compiler.get_decoration(item.id, spv::DecorationDescriptorSet);
      resource.binding = compiler.get_decoration(item.id, spv::DecorationBinding);
      resource.count = type.array.empty() ? 1u : type.array[0];
      if (is_block(kind)) {
        resource.size = checked_block_size(compiler, base_type, resource.name);
        resource.members = block_members(compiler, base_type);
      } else if (is_image(resource.kind)) {
        resource.dimension = image_dimension(base_type);
        resource.depth = base_type.image.depth;
      } else if (resource.kind == ResourceKind::InputAttachment) {
        resource.input_attachment_index = compiler.get_decoration(item.id, spv::DecorationInputAttachmentIndex);
      }
    }
  };
  add(resources.uniform_buffers, ResourceKind::UniformBuffer);
  add(resources.storage_buffers, ResourceKind::StorageBuffer);
  add(resources.separate_images, ResourceKind::Texture);
  add(resources.separate_samplers, ResourceKind::Sampler);
  add(resources.sampled_images, ResourceKind::CombinedImageSampler);
  add(resources.storage_images, ResourceKind::StorageImage);
  add(resources.subpass_inputs, ResourceKind::InputAttachment);
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

namespace {

// One descriptor for Vulkan: the same descriptor type, count, image dimension and arrayness ("2DArray").
bool same_descriptor(const Resource& a, const Resource& b) {
  return a.kind == b.kind && a.count == b.count && a.dimension == b.dimension;
}

std::string member_text(const BlockMember& m) {
  return "'" + m.name + "' (" + m.type + ", bytes " + std::to_string(m.offset) + "-" +
         std::to_string(m.offset + std::max<uint64_t>(m.size, 1) - 1) + ")";
}

// The first pair of members of two declarations of one block that overlap in bytes without being the same member
// (offset, size, type and array stride; the name may differ); empty when they agree wherever both have members.
std::string member_mismatch(const std::vector<BlockMember>& a, const std::vector<BlockMember>& b) {
  for (const BlockMember& x : a)
    for (const BlockMember& y : b) {
      const uint64_t x_end = x.offset + std::max<uint64_t>(x.size, 1), y_end = y.offset + std::max<uint64_t>(y.size, 1);
      const bool overlap = x.offset < y_end && y.offset < x_end;
      const bool same = x.offset == y.offset && x.size == y.size && x.type == y.type && x.array_stride == y.array_stride;
      if (overlap && !same) return member_text(x) + " and " + member_text(y);
    }
  return {};
}

// `into` grows to cover `from`: the larger size, and the members only `from` declares (by offset).
void widen_block(uint64_t& size, std::vector<BlockMember>& members, uint64_t from_size, const std::vector<BlockMember>& from) {
  size = std::max(size, from_size);
  for (const BlockMember& m : from) {
    const bool covered = std::any_of(members.begin(), members.end(), [&](const BlockMember& have) {
      return m.offset < have.offset + std::max<uint64_t>(have.size, 1) && have.offset < m.offset + std::max<uint64_t>(m.size, 1);
    });
    if (!covered) members.push_back(m);
  }
  std::stable_sort(members.begin(), members.end(), [](const BlockMember& x, const BlockMember& y) { return x.offset < y.offset; });
}

}  // namespace

MergedLayout merge_layouts(const std::vector<LayoutSource>& sources) {
  MergedLayout out;
  std::map<std::pair<uint32_t, uint32_t>, Resource> by_slot;  // (set, binding) -> the merged resource there
  std::map<std::pair<uint32_t, uint32_t>, const Resource*> first_at_slot;
  std::map<std::pair<Stage, std::pair<uint32_t, uint32_t>>, const Resource*> by_stage_slot;
  std::map<std::pair<Stage, std::string>, const Resource*> by_name;  // per stage: names are a stage's own
  std::optional<PushConstantBlock> push;
  const PushConstantBlock* first_push = nullptr;
  std::set<std::pair<std::string, std::string>> reported;
  auto clash = [&](LayoutClash item) {
    const std::string key = item.push_constants ? "push constants" : nlohmann::json(item.first).dump();
    if (reported.emplace(key, nlohmann::json(item.second).dump() + item.member).second) out.clashes.push_back(std::move(item));
  };
  for (const LayoutSource& source : sources) {
    for (const Resource& resource : source.reflection->resources) {
      const std::pair slot{resource.set, resource.binding};
      auto [at_slot, new_slot] = by_slot.emplace(slot, resource);
      // Within one stage, a name is one resource: two names at one binding alias two resources the author meant
      // apart (register(t0) and register(u0) of a shift-less D3D layout), whatever their descriptor types.
      auto [in_stage, new_in_stage] = by_stage_slot.emplace(std::make_pair(source.stage, slot), &resource);
      if (new_slot) {
        first_at_slot[slot] = &resource;
      } else if (const Resource& first = *first_at_slot[slot]; !same_descriptor(first, resource)) {
        clash({LayoutClash::Kind::SharedSlot, first, resource, false, {}});
      } else if (!new_in_stage && in_stage->second->name != resource.name) {
        clash({LayoutClash::Kind::SharedSlot, *in_stage->second, resource, false, {}});
      } else if (is_block(resource.kind)) {
        if (std::string why = member_mismatch(first.members, resource.members); !why.empty())
          clash({LayoutClash::Kind::MemberMismatch, first, resource, false, why});
        widen_block(at_slot->second.size, at_slot->second.members, resource.size, resource.members);
      }
      auto [named, new_name] = by_name.emplace(std::make_pair(source.stage, resource.name), &resource);
      if (!new_name && (named->second->set != resource.set || named->second->binding != resource.binding))
        clash({LayoutClash::Kind::MovedResource, *named->second, resource, false, {}});
    }
    for (const PushConstantBlock& block : source.reflection->push_constants) {
      if (!push) {
        push = block;
        first_push = &block;
        continue;
      }
      if (std::string why = member_mismatch(first_push->members, block.members); !why.empty()) {
        Resource a{.name = first_push->name, .size = first_push->size, .members = first_push->members};
        Resource b{.name = block.name, .size = block.size, .members = block.members};
        clash({LayoutClash::Kind::MemberMismatch, std::move(a), std::move(b), true, why});
      }
      widen_block(push->size, push->members, block.size, block.members);
    }
  }
  for (auto& [slot, resource] : by_slot) out.layout.resources.push_back(std::move(resource));
  if (push) out.layout.push_constants = {std::move(*push)};
  return out;
}

}  // namespace kiln
