// SPDX-License-Identifier: Apache-2.0
// The graphics APIs kiln renders a pack's outputs with, behind one interface: Vulkan (the SPIR-V, on Mesa
// lavapipe), OpenGL 4.5 core (the GLSL 450 output) and OpenGL ES 3.2 (the GLSL ES output), both on Mesa
// llvmpipe. `kiln render` and `kiln test` take --api.
#pragma once

#include <memory>
#include <string>

#include "coverage/coverage_recorder.hpp"
#include "kiln/pack_reader.hpp"
#include "scene/image.hpp"
#include "scene/scene.hpp"

namespace kiln::render {

enum class Api { Vulkan, Gl, Gles };
// "vulkan", "gl", "gles"; throws a VerifyError (K2005) for anything else.
Api parse_api(const std::string& name);
std::string api_name(Api api);

class Backend {
 public:
  // Opens the API's device and sets the scene up for the pack's Forward pass. Throws a VerifyError with
  // a clear message (no device, a pack or scene the renderer cannot use).
  static std::unique_ptr<Backend> open(Api api, const PackReader& pack, const Scene& scene, uint32_t width = 0,
                                       uint32_t height = 0);
  virtual ~Backend() = default;
  virtual Image render(const SelectedVariant& variant) = 0;
  virtual std::string device() const = 0;  // e.g. "lavapipe: llvmpipe (LLVM 15.0.6, 256 bits), Mesa 22.3.6"
  virtual uint32_t width() const = 0;
  virtual uint32_t height() const = 0;
  // Pipelines (Vulkan) or programs (GL) compiled for images, and renders that reused one instead.
  virtual size_t pipelines_created() const = 0;
  virtual size_t pipelines_reused() const = 0;
  // Each later draw's shader code coverage (a --coverage pack's) goes to `recorder` (nullptr: nowhere).
  virtual void record_coverage(CoverageRecorder* recorder) = 0;
  // The pack it was opened with has switched to a new version (PackReader::poll_update): its pipelines and what was
  // laid out from the old version's reflection point into a version the next poll frees, so the renderer is made
  // again from the pack served now, on the same device (kiln render --watch). Call it before the next render.
  virtual void reload() = 0;
};

}  // namespace kiln::render
