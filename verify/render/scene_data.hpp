// SPDX-License-Identifier: Apache-2.0
// What a scene puts into a pack's resources, independent of the graphics API: constant buffers filled at the
// member offsets the pack's reflection records, the light records and Forward+ tile lists, the shadow
// caster's per-view constants, the environment cube and the DFG table. The Vulkan renderer (lavapipe) and the
// OpenGL renderer (llvmpipe) upload the same bytes, so an image difference between them is a difference in
// the compiled shaders or the driver, never in the inputs.
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "kiln/pack_reader.hpp"
#include "kiln/manifest_json.hpp"
#include "scene/environment.hpp"
#include "scene/scene.hpp"
#include "scene/verify_error.hpp"

namespace kiln::render {

using Bytes = std::vector<uint8_t>;

// Throws a VerifyError (scene/verify_error.hpp): K2004 (the pack lacks what the renderer needs), or `id`.
[[noreturn]] void render_error(const std::string& message);
[[noreturn]] void render_error(DiagId id, const std::string& message);

// The DFG table shipped with the shader library (KDFG v3, see verify/reference/reference.hpp): RG float32.
struct DfgTable {
  uint32_t width = 0, height = 0;
  std::vector<float> rg;
};
DfgTable load_dfg(const std::filesystem::path& path);

// A pass of the pack by name; throws if the pack has no such pass.
const ManifestPass& find_pass(const PackReader& pack, const std::string& name);
// A resource of a pass's reflected layout by name, or null.
const Resource* find_resource(const ManifestPass& pass, const std::string& name);

// Fills a constant or storage buffer at the offsets a reflected block records. A member the reflection does
// not list (no variant of the pass reads it) is skipped.
class BlockWriter {
 public:
  explicit BlockWriter(const Resource& block);
  void floats(const std::string& member, std::initializer_list<double> values, size_t element = 0);
  void uints(const std::string& member, std::initializer_list<uint32_t> values);
  // HLSL float4x4 in a constant buffer is column-major: column c of M is stored at offset 16 c.
  void matrix(const std::string& member, const Mat4& m, size_t element = 0);
  Bytes take() { return std::move(bytes_); }

 private:
  void write(const std::string& member, const void* data, size_t size, size_t element);
  const Resource& block_;
  Bytes bytes_;
};

class SceneData {
 public:
  // `scene` with its final image size. Throws on a pack the renderers cannot feed (a missing pass or block,
  // a resource name no scene provides).
  SceneData(const PackReader& pack, const Scene& scene);

  const Scene& scene() const { return scene_; }
  const ManifestPass& forward_pass() const { return forward_; }
  const ManifestPass& shadow_pass() const { return shadow_; }
  const Environment& environment() const { return environment_; }
  const DfgTable& dfg() const { return dfg_; }

  struct Frame {
    FrameSetup setup;
    Bytes per_frame;
  };
  // The frame for a main-light shadow layout of `cascades` (1, or the scene's cascade count); made once.
  const Frame& frame(int cascades);

  // The bytes of a buffer the Forward, ShadowCaster or GBuffer pass binds, by its reflected name, for one
  // object of the scene. Throws for a name the scene does not provide.
  const Bytes& buffer(const std::string& name, size_t object, const Frame& frame) const;
  // The ShadowCaster pass's constants for one shadow view.
  Bytes caster_constants(const ShadowView& view) const;
  // Whether the pack can draw punctual-light shadow maps (a pack stripped of them has no Forward variant
  // that samples the atlas either).
  bool has_punctual_caster() const { return punctual_caster_; }

 private:
  const PackReader& pack_;
  Scene scene_;
  const ManifestPass& forward_;
  const ManifestPass& shadow_;
  Environment environment_;
  DfgTable dfg_;
  std::vector<Bytes> per_material_, per_object_;
  Bytes lights_, tiles_, shadow_matrices_;
  std::map<int, Frame> frames_;
  bool punctual_caster_ = false;
};

// Whether the renderers provide a resource of this reflected name.
bool is_provided_resource(const std::string& name);

// A vertex input a vertex stage reads, matched by its reflected name to the interleaved mesh layout (scene.hpp).
struct MeshAttribute {
  uint32_t location = 0;
  uint32_t components = 0;  // float32 each
  uint32_t offset = 0;      // bytes into the vertex
};
// Throws for an input the meshes do not have.
std::vector<MeshAttribute> mesh_attributes(const StageView& vertex);

}  // namespace kiln::render
