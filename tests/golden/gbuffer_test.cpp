// SPDX-License-Identifier: Apache-2.0
// The CPU reference rasterizes the scenes itself (verify/reference/rasterize.cpp) instead of reading the G-buffer
// and the shadow maps lavapipe draws: they must agree wherever the reference does not mark a coverage tie, which
// checks both the reference's rasterizer and the debug pack's GBuffer pass and the ShadowCaster pass. A wrong object
// transform or caster bias in either fails here.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "kiln/pack_reader.hpp"
#include "reference/rasterize.hpp"
#include "render/renderer.hpp"

namespace kiln::render {
namespace {

const std::filesystem::path kWork = KILN_GOLDEN_WORK;

struct Agreement {
  size_t covered = 0;           // pixels either G-buffer covers
  size_t ties = 0;              // coverage ties the reference marked
  size_t coverage_differs = 0;  // outside the ties
  size_t facing_differs = 0;
  double position = 0, normal = 0, tangent = 0, material = 0;  // largest absolute differences
  size_t tangent_over = 0;      // pixels whose tangent differs by more than 1e-3
};

Agreement agreement(const GBuffer& gpu, const GBuffer& cpu) {
  Agreement a;
  const size_t pixels = size_t(gpu.position.width) * gpu.position.height;
  auto worst = [&](const Image& x, const Image& y, size_t p, int channels, double& into) {
    for (int c = 0; c < channels; ++c) into = std::max(into, double(std::abs(x.rgba[p * 4 + c] - y.rgba[p * 4 + c])));
  };
  for (size_t p = 0; p < pixels; ++p) {
    const float g = gpu.position.rgba[p * 4 + 3], c = cpu.position.rgba[p * 4 + 3];
    if (g == 0 && c == 0) continue;
    ++a.covered;
    if (c == kUnstablePixel) {
      ++a.ties;
      continue;
    }
    if (g != c) {
      ++a.coverage_differs;
      continue;
    }
    a.facing_differs += gpu.normal.rgba[p * 4 + 3] != cpu.normal.rgba[p * 4 + 3];
    worst(gpu.position, cpu.position, p, 3, a.position);
    worst(gpu.normal, cpu.normal, p, 3, a.normal);
    double tangent = 0;
    worst(gpu.tangent, cpu.tangent, p, 4, tangent);
    a.tangent = std::max(a.tangent, tangent);
    a.tangent_over += tangent > 1e-3;
    worst(gpu.material0, cpu.material0, p, 4, a.material);
    worst(gpu.material1, cpu.material1, p, 3, a.material);
  }
  return a;
}

class ReferenceGeometry : public testing::TestWithParam<const char*> {};

TEST_P(ReferenceGeometry, TheReferencesOwnRasterizationAgreesWithLavapipesGBufferOutsideCoverageTies) {
  auto opened = VulkanContext::open_lavapipe();
  ASSERT_TRUE(opened) << opened.error().message;
  auto context = std::move(*opened);
  PackReader pack = PackReader::open(kWork / "packs/lit");
  PackReader debug = PackReader::open(kWork / "packs/debug");
  const Scene scene = load_scene(std::filesystem::path(KILN_SOURCE_DIR) / "variants/scenes/render" / (std::string(GetParam()) + ".json"));
  SceneRenderer renderer(*context, pack, scene);
  const GBuffer gpu = renderer.render_gbuffer(debug);
  const GBuffer cpu = reference::rasterize_gbuffer(scene, renderer.frame(1).view_projection, renderer.width(), renderer.height());
  const Agreement a = agreement(gpu, cpu);
  std::cout << "[ geometry ] " << GetParam() << ": " << a.covered << " covered pixels, " << a.ties << " coverage ties ("
            << 100.0 * a.ties / a.covered << "%), " << a.coverage_differs << " differ in coverage outside them; largest "
            << "differences: position " << a.position << ", normal " << a.normal << ", tangent " << a.tangent
            << " (" << a.tangent_over << " pixels over 1e-3), material " << a.material << "\n";
  EXPECT_GT(a.covered, size_t(renderer.width()) * renderer.height() / 2);
  EXPECT_EQ(a.coverage_differs, 0u);
  EXPECT_EQ(a.facing_differs, 0u);
  EXPECT_LT(a.ties, a.covered / 200) << "coverage ties must stay rare: they are skipped by every comparison";
  // fp32 vertex transforms, vertices snapped to 1/256 pixel and fp32 interpolation against double (measured:
  // position 3.6e-5, normal 7.9e-5 at most, in metres and unit vectors).
  EXPECT_LT(a.position, 1e-4);
  EXPECT_LT(a.normal, 2e-4);
  // Tangents turn by a whole revolution around a sphere's poles, so the snapped barycentrics of the pole
  // triangles move them most (measured: 0.033 at worst, on a handful of pixels).
  EXPECT_LT(a.tangent, 0.05);
  EXPECT_LT(a.tangent_over, a.covered / 2000) << a.tangent_over << " pixels with a tangent over 1e-3 off";
  EXPECT_EQ(a.material, 0);
}

// The shadow atlases: the same caster coverage outside the tie texels, depths within what fp32 transforms and
// vertices snapped to 1/256 texel move them.
struct AtlasAgreement {
  size_t covered = 0, ties = 0, coverage_differs = 0;
  size_t depth_outside_tolerance = 0;  // texels whose depths differ by more than the reference's tolerance + 2e-6
  double depth = 0;
};

AtlasAgreement agreement(const ShadowAtlas& gpu, const ShadowAtlas& cpu) {
  AtlasAgreement a;
  for (size_t i = 0; i < gpu.depth.size(); ++i) {
    const bool g = gpu.depth[i] < 1, c = cpu.depth[i] < 1;
    if (!g && !c) continue;
    ++a.covered;
    if (cpu.tie[i]) {
      ++a.ties;
      continue;
    }
    if (g != c) {
      ++a.coverage_differs;
      continue;
    }
    const double difference = std::abs(double(gpu.depth[i]) - double(cpu.depth[i]));
    a.depth = std::max(a.depth, difference);
    a.depth_outside_tolerance += difference > 2e-6 + cpu.depth_tolerance[i];
  }
  return a;
}

TEST_P(ReferenceGeometry, TheReferencesOwnShadowMapsAgreeWithTheShadowCasterPassOutsideCoverageTies) {
  auto opened = VulkanContext::open_lavapipe();
  ASSERT_TRUE(opened) << opened.error().message;
  auto context = std::move(*opened);
  PackReader pack = PackReader::open(kWork / "packs/lit");
  const Scene scene = load_scene(std::filesystem::path(KILN_SOURCE_DIR) / "variants/scenes/render" / (std::string(GetParam()) + ".json"));
  SceneRenderer renderer(*context, pack, scene);
  struct Atlas {
    const char* name;
    ShadowAtlas gpu, cpu;
  };
  std::vector<Atlas> atlases;
  for (int cascades : {1, 4}) {
    const FrameSetup& f = renderer.frame(cascades);
    atlases.push_back({cascades == 1 ? "main light" : "main light, 4 cascades", renderer.main_shadow_atlas(cascades),
                       reference::rasterize_shadow_atlas(scene, f.main_views, f.main_atlas_size, f.main_atlas_size, scene.main_shadow)});
  }
  const FrameSetup& f = renderer.frame(1);
  if (!f.additional_views.empty())
    atlases.push_back({"additional lights", renderer.additional_shadow_atlas(),
                       reference::rasterize_shadow_atlas(scene, f.additional_views, f.additional_atlas_width,
                                                         f.additional_atlas_height, scene.additional_shadow)});
  for (const Atlas& atlas : atlases) {
    SCOPED_TRACE(atlas.name);
    ASSERT_EQ(atlas.gpu.depth.size(), atlas.cpu.depth.size());
    const AtlasAgreement a = agreement(atlas.gpu, atlas.cpu);
    std::cout << "[ geometry ] " << GetParam() << ", " << atlas.name << ": " << a.covered << " covered texels, " << a.ties
              << " ties, " << a.coverage_differs << " differ in coverage outside them, depth within " << a.depth << " ("
              << a.depth_outside_tolerance << " texels beyond the reference's tolerance)\n";
    EXPECT_GT(a.covered, 0u);
    EXPECT_EQ(a.coverage_differs, 0u);
    EXPECT_LT(a.ties, a.covered / 100);
    // Depths: within how far the reference's depth moves over the tie distance (vertex snapping), plus fp32.
    EXPECT_EQ(a.depth_outside_tolerance, 0u);
    EXPECT_LT(a.depth, 1e-4);
  }
}

INSTANTIATE_TEST_SUITE_P(Scenes, ReferenceGeometry, testing::Values("spheres", "audit", "night_city"),
                         [](const testing::TestParamInfo<const char*>& param) { return std::string(param.param); });

}  // namespace
}  // namespace kiln::render
