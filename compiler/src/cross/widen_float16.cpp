// SPDX-License-Identifier: Apache-2.0
#include "cross/widen_float16.hpp"
#include "optimize/spirv_tools.hpp"

#define SPV_ENABLE_UTILITY_CODE
#include <spirv_cross/spirv.hpp>

#include <spirv-tools/optimizer.hpp>

#include <cstring>
#include <map>
#include <set>

namespace kiln {
namespace {

// IEEE 754 binary16 to binary32 bits (all classes: zero, subnormal, normal, infinity, NaN).
uint32_t half_to_float_bits(uint16_t h) {
  uint32_t sign = uint32_t(h & 0x8000u) << 16;
  uint32_t exponent = (h >> 10) & 0x1fu;
  uint32_t mantissa = h & 0x3ffu;
  if (exponent == 0x1f) return sign | 0x7f800000u | (mantissa << 13);
  if (exponent == 0) {
    if (mantissa == 0) return sign;
    // Subnormal: normalize.
    int shift = 0;
    while ((mantissa & 0x400u) == 0) {
      mantissa <<= 1;
      ++shift;
    }
    mantissa &= 0x3ffu;
    return sign | (uint32_t(127 - 15 - shift + 1) << 23) | (mantissa << 13);
  }
  return sign | ((exponent + 127 - 15) << 23) | (mantissa << 13);
}

struct Instruction {
  size_t offset;  // index of the first word
  spv::Op op;
  uint32_t words;
};

std::vector<Instruction> instructions(const std::vector<uint32_t>& spirv) {
  std::vector<Instruction> list;
  for (size_t i = 5; i < spirv.size();) {
    uint32_t words = spirv[i] >> 16;
    if (words == 0 || i + words > spirv.size()) return {};
    list.push_back({i, static_cast<spv::Op>(spirv[i] & 0xffffu), words});
    i += words;
  }
  return list;
}

bool is_type_declaration(spv::Op op) { return op >= spv::OpTypeVoid && op <= spv::OpTypeForwardPointer; }

}  // namespace

Result<Widened> widen_float16_for_gl(const std::vector<uint32_t>& spirv) {
  Widened result;
  result.spirv = spirv;
  std::vector<Instruction> list = instructions(spirv);
  if (list.empty()) return failure("not a SPIR-V module");

  // Scan: the 16-bit float capability, storage capabilities that forbid widening, half-based types, the
  // type of every value.
  bool float16 = false;
  std::set<uint32_t> half_scalars, half_based;  // half_based: scalars, vectors and matrices of 16-bit floats
  std::map<uint32_t, uint32_t> value_type;
  std::map<uint32_t, uint32_t> float_width;  // scalar float type -> width; vectors and matrices -> component's
  for (const Instruction& in : list) {
    const uint32_t* w = &spirv[in.offset];
    switch (in.op) {
      case spv::OpCapability:
        if (w[1] == spv::CapabilityFloat16) float16 = true;
        if (w[1] == spv::CapabilityStorageBuffer16BitAccess || w[1] == spv::CapabilityUniformAndStorageBuffer16BitAccess ||
            w[1] == spv::CapabilityStoragePushConstant16 || w[1] == spv::CapabilityStorageInputOutput16) {
          result.unchanged_because = "16-bit storage or interface types: widening would change a memory layout";
          return result;
        }
        break;
      case spv::OpTypeFloat:
        float_width[w[1]] = w[2];
        if (w[2] == 16) half_scalars.insert(w[1]), half_based.insert(w[1]);
        break;
      case spv::OpTypeVector:
      case spv::OpTypeMatrix:
        if (float_width.count(w[2])) float_width[w[1]] = float_width[w[2]];
        if (half_based.count(w[2])) half_based.insert(w[1]);
        break;
      default: {
        bool has_result = false, has_type = false;
        spv::HasResultAndType(in.op, &has_result, &has_type);
        if (has_result && has_type && in.words >= 3) value_type[w[2]] = w[1];
      }
    }
  }
  if (!float16 || half_scalars.empty()) {
    result.unchanged_because = "no 16-bit floats";
    return result;
  }
  auto width_after = [&](uint32_t type) {
    auto it = float_width.find(type);
    if (it == float_width.end()) return 0u;
    return it->second == 16 ? 32u : it->second;
  };

  // Rewrite.
  std::vector<uint32_t> out(spirv.begin(), spirv.begin() + 5);
  std::vector<uint32_t> relaxed;  // values computed in 16 bits: mediump in GLSL ES
  size_t decorations_at = 0;      // where the RelaxedPrecision decorations go: before the first type
  bool in_function = false;
  for (const Instruction& in : list) {
    std::vector<uint32_t> w(spirv.begin() + in.offset, spirv.begin() + in.offset + in.words);
    if (in.op == spv::OpCapability && w[1] == spv::CapabilityFloat16) continue;
    if (decorations_at == 0 && is_type_declaration(in.op)) decorations_at = out.size();
    switch (in.op) {
      case spv::OpTypeFloat:
        if (w[2] == 16) w[2] = 32;
        break;
      case spv::OpConstant:
      case spv::OpSpecConstant:
        if (half_scalars.count(w[1])) w[3] = half_to_float_bits(static_cast<uint16_t>(w[3] & 0xffffu));
        break;
      case spv::OpFunction: in_function = true; break;
      case spv::OpFunctionEnd: in_function = false; break;
      case spv::OpFConvert:
        // half <-> float becomes float -> float: a copy.
        if (value_type.count(w[3]) && width_after(w[1]) == width_after(value_type[w[3]])) {
          w[0] = (4u << 16) | spv::OpCopyObject;
          w.resize(4);
        }
        break;
      default: break;
    }
    if (in_function && in.op != spv::OpVariable && in.op != spv::OpFunction && in.words >= 3) {
      bool has_result = false, has_type = false;
      spv::HasResultAndType(in.op, &has_result, &has_type);
      if (has_result && has_type && half_based.count(w[1])) relaxed.push_back(w[2]);
    }
    out.insert(out.end(), w.begin(), w.end());
  }
  std::vector<uint32_t> decorations;
  for (uint32_t id : relaxed) decorations.insert(decorations.end(), {(3u << 16) | spv::OpDecorate, id, spv::DecorationRelaxedPrecision});
  out.insert(out.begin() + static_cast<std::ptrdiff_t>(decorations_at), decorations.begin(), decorations.end());

  // The widened half types now duplicate the 32-bit ones: merge them.
  spvtools::Optimizer optimizer(spirv_tools_environment());
  std::string messages;
  optimizer.SetMessageConsumer([&](spv_message_level_t, const char*, const spv_position_t&, const char* message) {
    messages += message;
    messages += "\n";
  });
  optimizer.RegisterPass(spvtools::CreateRemoveDuplicatesPass());
  spvtools::OptimizerOptions options;
  options.set_run_validator(false);
  std::vector<uint32_t> merged;
  if (!optimizer.Run(out.data(), out.size(), &merged, options)) return failure("merging widened types failed: " + messages);
  result.spirv = std::move(merged);
  result.changed = true;
  return result;
}

}  // namespace kiln
