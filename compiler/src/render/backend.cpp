#include "render/backend.hpp"

#include <stdexcept>

#include "render/gl_renderer.hpp"
#include "render/renderer.hpp"

namespace kiln::render {

Api parse_api(const std::string& name) {
  if (name == "vulkan") return Api::Vulkan;
  if (name == "gl") return Api::Gl;
  if (name == "gles") return Api::Gles;
  throw std::runtime_error("kiln: error: unknown API '" + name + "' (vulkan, gl or gles)");
}

std::string api_name(Api api) {
  switch (api) {
    case Api::Vulkan: return "vulkan";
    case Api::Gl: return "gl";
    case Api::Gles: return "gles";
  }
  return "?";
}

namespace {

class VulkanBackend final : public Backend {
 public:
  VulkanBackend(std::unique_ptr<VulkanContext> context, const PackReader& pack, const Scene& scene, uint32_t width,
                uint32_t height)
      : context_(std::move(context)), renderer_(*context_, pack, scene, width, height) {}
  Image render(const SelectedVariant& variant) override { return renderer_.render(variant); }
  std::string device() const override {
    return "Vulkan on " + context_->device_name() + " (" + context_->driver_info() + ")";
  }
  uint32_t width() const override { return renderer_.width(); }
  uint32_t height() const override { return renderer_.height(); }

 private:
  std::unique_ptr<VulkanContext> context_;
  SceneRenderer renderer_;
};

class GlBackend final : public Backend {
 public:
  GlBackend(std::unique_ptr<GlContext> context, const PackReader& pack, const Scene& scene, uint32_t width,
            uint32_t height)
      : context_(std::move(context)), renderer_(*context_, pack, scene, width, height) {}
  Image render(const SelectedVariant& variant) override { return renderer_.render(variant); }
  std::string device() const override {
    return std::string(context_->api() == GlApi::Gles32 ? "GLSL ES" : "GLSL 450") + " on " + context_->renderer();
  }
  uint32_t width() const override { return renderer_.width(); }
  uint32_t height() const override { return renderer_.height(); }

 private:
  std::unique_ptr<GlContext> context_;
  GlSceneRenderer renderer_;
};

}  // namespace

std::unique_ptr<Backend> Backend::open(Api api, const PackReader& pack, const Scene& scene, uint32_t width,
                                       uint32_t height) {
  std::string error;
  if (api == Api::Vulkan) {
    auto context = VulkanContext::open_lavapipe(error);
    if (!context) throw std::runtime_error("kiln render: error: " + error);
    return std::make_unique<VulkanBackend>(std::move(context), pack, scene, width, height);
  }
  auto context = GlContext::open(api == Api::Gles ? GlApi::Gles32 : GlApi::DesktopGl45, error);
  if (!context) throw std::runtime_error("kiln render: error: " + error);
  return std::make_unique<GlBackend>(std::move(context), pack, scene, width, height);
}

}  // namespace kiln::render
