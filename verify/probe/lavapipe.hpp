// SPDX-License-Identifier: Apache-2.0
// Runs shaderlib code on Mesa lavapipe (CPU Vulkan): the GPU side of the stress gate and of the
// cost-versus-error study. A probe is a full-screen triangle whose fragment shader reads one input record
// per pixel from a storage buffer and writes one float4 per pixel to an RGBA32F image, which is read back.
// Probe shaders are compiled by kiln's own front end and SPIRV-Tools steps (the code the packs ship).
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "kiln/result.hpp"

namespace kiln::gpu {

// One input record: four float4 (a, b, c, d), as tests/gpu/Probe.hlsl declares ProbeInput.
using ProbeInput = std::array<float, 16>;
using ProbeOutput = std::array<float, 4>;

// Width of the probe image; Probe.hlsl derives the record index as y * kProbeWidth + x.
inline constexpr uint32_t kProbeWidth = 128;
// Descriptor binding of the input records (set 0), away from the library's own bindings.
inline constexpr uint32_t kProbeInputBinding = 20;

struct ProbeProgram {
  std::vector<uint32_t> vertex;
  std::vector<uint32_t> fragment;  // optimized, as kiln build ships it
  bool float16 = false;            // uses explicit 16-bit floats (needs shaderFloat16)
};

// An optional 2D texture bound at `binding` with a linear-clamp sampler at `sampler_binding`: the DFG table.
struct ProbeTexture {
  enum class Format { Rg32f, Rg16Unorm, Rg8Unorm };
  Format format = Format::Rg32f;
  uint32_t width = 0;
  uint32_t height = 0;
  std::vector<float> texels;  // width * height * 2, quantized to the format on upload
  uint32_t binding = 0;
  uint32_t sampler_binding = 0;
};

// An extra buffer bound in set 0 (the library's own resources, e.g. PerFrame at 0, _AdditionalLights at 9).
struct ProbeBuffer {
  uint32_t binding = 0;
  bool uniform = false;  // uniform buffer, else storage buffer
  std::vector<uint8_t> bytes;
};

class Lavapipe {
 public:
  // Opens the lavapipe device explicitly (by driver name), never another GPU. The error says what is missing.
  static Result<std::unique_ptr<Lavapipe>> open();
  ~Lavapipe();
  Lavapipe(const Lavapipe&) = delete;
  Lavapipe& operator=(const Lavapipe&) = delete;

  std::string device_name() const;
  std::string driver_info() const;
  bool supports_float16() const;

  // Evaluates the probe once per input record. `milliseconds`, when given, receives the wall time of the
  // draw alone (submit to idle), for the secondary cost axis.
  std::vector<ProbeOutput> run(const ProbeProgram& program, const std::vector<ProbeInput>& inputs,
                               const std::optional<ProbeTexture>& texture = std::nullopt,
                               double* milliseconds = nullptr, const std::vector<ProbeBuffer>& buffers = {});

 private:
  struct State;
  explicit Lavapipe(std::unique_ptr<State> state);
  std::unique_ptr<State> state_;
};

// Compiles `probe_file` (vertex ProbeVertex, fragment ProbeFragment) with `#define NAME 1` for each define,
// includes resolved in `include_dirs`, through kiln's glslang front end, legalization, spirv-val and
// (if `optimize`) spirv-opt. The error names the step that failed and its messages.
Result<ProbeProgram> compile_probe(const std::filesystem::path& probe_file, const std::vector<std::filesystem::path>& include_dirs,
                                   const std::vector<std::string>& defines, bool optimize = true);

// Weighted instruction count of a SPIR-V module (the primary shading-cost axis): ALU 1; rcp, sqrt,
// inverse sqrt, exp2, log2, exp, log, sin, cos 4; divide 5; pow 9; texture fetches counted separately.
struct ShaderCost {
  double weighted = 0;
  uint32_t instructions = 0;
  uint32_t texture_fetches = 0;
};
ShaderCost weighted_cost(const std::vector<uint32_t>& spirv);
// The weights above, in words, for reports.
std::string cost_weights_description();

}  // namespace kiln::gpu
