// SPDX-License-Identifier: Apache-2.0
// The default pack's DepthOnly and DepthNormals variants, rendered on each API (their SPIR-V on lavapipe, their
// GLSL 450 and GLSL ES on llvmpipe) in the golden scene, against what they must write for the geometry the
// debug pack's G-buffer records: DepthNormals the encoded, normalized world normal; DepthOnly the window depth
// of the world position under the camera's view-projection, computed here in double. Uses the packs that
// golden.setup builds.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "kiln/pack_reader.hpp"
#include "kiln/manifest_json.hpp"
#include "render/backend.hpp"
#include "render/renderer.hpp"

namespace kiln::render {
namespace {

const std::filesystem::path kWork = KILN_GOLDEN_WORK;
const std::filesystem::path kScene = std::filesystem::path(KILN_SOURCE_DIR) / "variants/scenes/render/spheres.json";

// What the G-buffer says, shared by every API's test (rendered once on lavapipe).
struct Geometry {
  GBuffer gbuffer;
  Mat4 view_projection;
  uint32_t width = 0, height = 0;
};

const Geometry& geometry() {
  static const Geometry g = [] {
    auto opened = VulkanContext::open_lavapipe();
    if (!opened) throw std::runtime_error(opened.error().message);
    auto context = std::move(*opened);
    PackReader pack = PackReader::open(kWork / "packs/lit");
    PackReader debug = PackReader::open(kWork / "packs/debug");
    SceneRenderer renderer(*context, pack, load_scene(kScene));
    Geometry out;
    out.gbuffer = renderer.render_gbuffer(debug);
    out.view_projection = renderer.frame(1).view_projection;
    out.width = renderer.width();
    out.height = renderer.height();
    return out;
  }();
  return g;
}

struct Mismatch {
  size_t pixels = 0;    // compared (covered in the G-buffer)
  size_t over = 0;      // with a channel over the limit
  double worst = 0;     // largest channel difference
  size_t background = 0;  // uncovered pixels the pass wrote
};

// `expected(p, out)` fills the expected RGBA of covered pixel p; uncovered pixels must stay cleared (0).
template <typename Expected>
Mismatch compare(const Image& image, double limit, Expected expected) {
  const Geometry& g = geometry();
  Mismatch m;
  for (size_t p = 0; p < size_t(g.width) * g.height; ++p) {
    const float* got = &image.rgba[p * 4];
    if (g.gbuffer.position.rgba[p * 4 + 3] != 1.0f) {
      m.background += (got[0] != 0 || got[1] != 0 || got[2] != 0 || got[3] != 0);
      continue;
    }
    double want[4];
    expected(p, want);
    ++m.pixels;
    double worst = 0;
    for (int c = 0; c < 4; ++c) worst = std::max(worst, std::abs(got[c] - want[c]));
    m.worst = std::max(m.worst, worst);
    m.over += worst > limit;
  }
  return m;
}

class DepthPasses : public ::testing::TestWithParam<Api> {
 protected:
  Image render(const std::string& pass) {
    PackReader pack = PackReader::open(kWork / "packs/lit");
    auto backend = Backend::open(GetParam(), pack, load_scene(kScene));
    EXPECT_EQ(backend->width(), geometry().width);
    return backend->render(pack.select(pass, {}));
  }
};

TEST_P(DepthPasses, DepthNormalsWritesTheEncodedWorldNormal) {
  Image image = render("DepthNormals");
  const GBuffer& g = geometry().gbuffer;
  // 1e-4 of the encoded value: llvmpipe GL's normalize() differs from the exact one by up to 5e-5.
  Mismatch m = compare(image, 1e-4, [&](size_t p, double* want) {
    const float* n = &g.normal.rgba[p * 4];
    double length = std::sqrt(double(n[0]) * n[0] + double(n[1]) * n[1] + double(n[2]) * n[2]);
    for (int c = 0; c < 3; ++c) want[c] = n[c] / length * 0.5 + 0.5;
    want[3] = 1.0;
  });
  EXPECT_GT(m.pixels, 10000u);
  EXPECT_EQ(m.over, 0u) << "worst channel difference " << m.worst;
  EXPECT_EQ(m.background, 0u);
  std::cout << api_name(GetParam()) << " DepthNormals: " << m.pixels << " pixels, worst difference " << m.worst << "\n";
}

TEST_P(DepthPasses, DepthOnlyWritesTheWindowDepthOfTheGeometry) {
  Image image = render("DepthOnly");
  const Geometry& geo = geometry();
  // 2e-6: fp32 interpolation of the depth against the reprojected fp32 world position (measured 2.1e-7).
  Mismatch m = compare(image, 2e-6, [&](size_t p, double* want) {
    const float* x = &geo.gbuffer.position.rgba[p * 4];
    std::array<double, 4> clip = mat_apply(geo.view_projection, {x[0], x[1], x[2], 1.0});
    want[0] = clip[2] / clip[3];
    want[1] = want[2] = 0.0;
    want[3] = 1.0;
  });
  EXPECT_GT(m.pixels, 10000u);
  EXPECT_EQ(m.over, 0u) << "worst difference " << m.worst;
  EXPECT_EQ(m.background, 0u);
  std::cout << api_name(GetParam()) << " DepthOnly: " << m.pixels << " pixels, worst difference " << m.worst << "\n";
}

INSTANTIATE_TEST_SUITE_P(EveryApi, DepthPasses, ::testing::Values(Api::Vulkan, Api::Gl, Api::Gles),
                         [](const auto& parameter) { return api_name(parameter.param); });

}  // namespace
}  // namespace kiln::render
