// SPDX-License-Identifier: Apache-2.0
#include "render/backend.hpp"

#include <optional>
#include <stdexcept>

#include "render/gl_renderer.hpp"
#include "render/renderer.hpp"
#include "scene/verify_error.hpp"

namespace kiln::render {

Api parse_api(const std::string& name) {
  if (name == "vulkan") return Api::Vulkan;
  if (name == "gl") return Api::Gl;
  if (name == "gles") return Api::Gles;
  fail(DiagId::VerifyArgument, {}, "unknown API '" + name + "' (vulkan, gl or gles)");
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

// A context and the renderer that draws with it; `device` describes them for reports.
template <typename Context, typename Renderer>
class ContextBackend final : public Backend {
 public:
  ContextBackend(std::unique_ptr<Context> context, const PackReader& pack, const Scene& scene, uint32_t width,
                 uint32_t height, std::string device)
      : context_(std::move(context)), pack_(pack), scene_(scene), width_(width), height_(height), device_(std::move(device)) {
    renderer_.emplace(*context_, pack_, scene_, width_, height_);
  }
  Image render(const SelectedVariant& variant) override { return renderer().render(variant); }
  std::string device() const override { return device_; }
  uint32_t width() const override { return renderer().width(); }
  uint32_t height() const override { return renderer().height(); }
  size_t pipelines_created() const override { return renderer().pipelines_created(); }
  size_t pipelines_reused() const override { return renderer().pipelines_reused(); }
  void record_coverage(CoverageRecorder* recorder) override {
    coverage_ = recorder;
    renderer().record_coverage(recorder);
  }
  void reload() override {
    renderer_.reset();  // first: its objects belong to the device, which stays
    renderer_.emplace(*context_, pack_, scene_, width_, height_);
    renderer_->record_coverage(coverage_);
  }

 private:
  // Empty only after a reload() that threw (a new pack this renderer cannot use); the next reload() tries again.
  Renderer& renderer() const {
    if (!renderer_) fail(DiagId::PackUnusable, {}, "the renderer could not be set up from the pack served now");
    return *renderer_;
  }
  std::unique_ptr<Context> context_;
  const PackReader& pack_;
  Scene scene_;
  uint32_t width_, height_;
  std::string device_;
  CoverageRecorder* coverage_ = nullptr;
  mutable std::optional<Renderer> renderer_;  // destroyed before context_ (declared after it)
};

}  // namespace

std::unique_ptr<Backend> Backend::open(Api api, const PackReader& pack, const Scene& scene, uint32_t width,
                                       uint32_t height) {
  if (api == Api::Vulkan) {
    Result<std::unique_ptr<VulkanContext>> opened = VulkanContext::open_lavapipe();
    if (!opened) fail(DiagId::DeviceUnavailable, {}, opened.error().message);
    std::unique_ptr<VulkanContext> context = std::move(*opened);
    std::string device = "Vulkan on " + context->device_name() + " (" + context->driver_info() + ")";
    return std::make_unique<ContextBackend<VulkanContext, SceneRenderer>>(std::move(context), pack, scene, width,
                                                                          height, std::move(device));
  }
  Result<std::unique_ptr<GlContext>> opened = GlContext::open(api == Api::Gles ? GlApi::Gles32 : GlApi::DesktopGl45);
  if (!opened) fail(DiagId::DeviceUnavailable, {}, opened.error().message);
  std::unique_ptr<GlContext> context = std::move(*opened);
  std::string device = std::string(api == Api::Gles ? "GLSL ES" : "GLSL 450") + " on " + context->renderer();
  return std::make_unique<ContextBackend<GlContext, GlSceneRenderer>>(std::move(context), pack, scene, width, height,
                                                                      std::move(device));
}

}  // namespace kiln::render
