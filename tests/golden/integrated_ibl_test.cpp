// SPDX-License-Identifier: Apache-2.0
// A reference that shares nothing it judges (issue 23 item 3): for a set of variants, the CPU reference integrates
// the image-based lighting from the analytic sky itself (GGX importance sampling for the specular lobe, cosine
// sampling for the diffuse part; specular albedo and energy compensation from the same samples), instead of
// sampling the SH9 coefficients, the prefiltered cube and the DFG table the shader samples. lavapipe's images of the
// default pack are compared with it; what differs is the split-sum approximation, the SH9 truncation, the 32-texel
// cube and the DFG table's interpolation, measured here (docs/golden.md lists the figures). The integration's own
// noise is measured too (two decorrelated integrations), and a shared input made wrong (the SH9 band-1 sign, which
// both the shader and the table-sampling reference read) passes the table-sampling comparison and fails this one.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <iostream>
#include <thread>

#include "golden/golden.hpp"
#include "reference/scene_inputs.hpp"
#include "kiln/pack_reader.hpp"
#include "parallel.hpp"
#include "reference/scene_reference.hpp"
#include "render/renderer.hpp"
#include "render/vulkan_context.hpp"
#include "scene/image.hpp"

namespace kiln::render {
namespace {

const std::filesystem::path kWork = KILN_GOLDEN_WORK;
const std::filesystem::path kScene = std::filesystem::path(KILN_SOURCE_DIR) / "variants/scenes/render/spheres.json";
constexpr uint32_t kSamples = 512;  // GGX samples per pixel (128 cosine samples)

// The variants judged: the isotropic full-BRDF models, in fp32 and fp16, with and without energy compensation,
// tone-mapped and linear (linear output compares radiance without the tone curve's compression).
const std::vector<std::vector<std::string>> kVariants = {
    {}, {"_MULTISCATTER"}, {"_HALF_PRECISION"}, {"_HALF_PRECISION", "_MULTISCATTER"}, {"_LINEAR_OUTPUT", "_MULTISCATTER"}};

bool linear_output(const std::vector<std::string>& keywords) {
  return std::find(keywords.begin(), keywords.end(), "_LINEAR_OUTPUT") != keywords.end();
}

// What the integrated reference allows: the approximations' measured error (fp32 and fp16 alike; the worst
// variant's figures are in docs/golden.md) with a margin of at most 1.3x.
ComparisonLimits integrated_limits() {
  ComparisonLimits limits;
  limits.max_channel_difference = KILN_INTEGRATED_MAX_DIFFERENCE;
  limits.max_fraction_over = KILN_INTEGRATED_MAX_FRACTION;
  limits.max_relative_rmse = KILN_INTEGRATED_MAX_RMSE;
  // The worst pixel is not judged here: at grazing silhouettes the integration's own noise reaches 79/255.
  limits.max_worst_difference = 255;
  limits.max_fraction_skipped = KILN_INTEGRATED_MAX_SKIPPED;
  limits.classes = {"integrated_ibl"};
  return limits;
}

std::string describe(const Comparison& c) { return describe_comparison(c, integrated_limits()); }

struct Judged {
  PackReader pack = PackReader::open(kWork / "packs/lit");
  Scene scene = load_scene(kScene);
  std::unique_ptr<VulkanContext> context;
  std::unique_ptr<SceneRenderer> renderer;
  std::unique_ptr<reference::SceneInputs> inputs;

  explicit Judged(const std::filesystem::path& environment = {}) {
    if (!environment.empty()) scene.environment = environment;
    auto opened = VulkanContext::open_lavapipe();
    if (!opened) throw std::runtime_error(opened.error().message);
    context = std::move(*opened);
    renderer = std::make_unique<SceneRenderer>(*context, pack, scene);
    inputs = std::make_unique<reference::SceneInputs>(renderer->scene());
    for (const auto& keywords : kVariants) inputs->prepare(keywords);
  }
  // The references of every judged variant, shaded on all cores.
  std::vector<Image> shade(uint32_t samples, uint32_t salt = 0, size_t count = kVariants.size()) {
    std::vector<Image> images(count);
    kiln::parallel_for(count, std::max(1u, std::thread::hardware_concurrency()), [&](size_t i) {
      reference::ReferenceInputs in = inputs->inputs(kVariants[i]);
      in.integrate_environment_samples = samples;
      in.sample_salt = salt;
      images[i] = reference::shade_image(in, kVariants[i]);
    });
    return images;
  }
};

TEST(IntegratedEnvironment, LavapipesImagesMatchTheSkyIntegratedWithinTheMeasuredApproximationError) {
  Judged s;
  const std::vector<Image> integrated = s.shade(kSamples);
  const size_t noise_measured = 2;  // the integration's noise, on fp32 with and without energy compensation
  const std::vector<Image> again = s.shade(kSamples, 1, noise_measured);
  const std::vector<Image> table = s.shade(0);
  const ComparisonLimits limits = integrated_limits();
  for (size_t i = 0; i < kVariants.size(); ++i) {
    const std::string name = variant_name(kVariants[i]);
    SCOPED_TRACE(name.empty() ? "(no keywords)" : name);
    const bool linear = linear_output(kVariants[i]);
    Image rendered = s.renderer->render(s.pack.select("Forward", kVariants[i]));
    // The figures: the approximations as the table-sampling reference makes them, and as the shader does.
    Comparison approximations = compare_images(table[i], integrated[i], linear, limits);
    Comparison shader = compare_images(rendered, integrated[i], linear, limits);
    std::cout << "[ integrated ] " << (name.empty() ? "(no keywords)" : name) << ": lavapipe " << describe(shader)
              << "; table-sampling reference " << describe(approximations) << "\n";
    if (i < noise_measured) {
      // The integration's noise: two decorrelated integrations differ by sqrt(2) x its standard error.
      Comparison noise = compare_images(again[i], integrated[i], linear, limits);
      std::cout << "[ integrated ] " << (name.empty() ? "(no keywords)" : name) << ": integration noise " << describe(noise) << "\n";
      EXPECT_LT(noise.relative_rmse, limits.max_relative_rmse / 4) << "the integration is too noisy to judge";
      EXPECT_LT(noise.fraction_over, limits.max_fraction_over / 10) << "the integration is too noisy to judge";
    }
    // KILN_INTEGRATED_DUMP=DIR writes the images and their difference (x 16) there.
    if (const char* dump = std::getenv("KILN_INTEGRATED_DUMP"))
      write_failure_images(dump, "variant" + std::to_string(i), rendered, integrated[i], linear, name, describe(shader));
    EXPECT_TRUE(shader.passed) << describe(shader);
  }
}

// The SH9 coefficients are data the shader and the table-sampling reference both read: with the band-1 y term's
// sign flipped (sky and ground irradiance swapped) they still agree with each other, and only the integrated
// reference sees it.
TEST(IntegratedEnvironment, AWrongSharedEnvironmentPassesTheTableReferenceAndFailsTheIntegratedOne) {
  Environment environment = load_environment(load_scene(kScene).environment);
  for (float& c : environment.sh[1]) c = -c;
  const std::filesystem::path broken = std::filesystem::temp_directory_path() / ("kiln-broken-sh-" + std::to_string(::getpid()) + ".kenv");
  write_output(broken, encode_environment(environment));
  Judged s(broken);
  const size_t judged = 2;  // fp32 with and without energy compensation
  const std::vector<Image> integrated = s.shade(kSamples, 0, judged);
  const std::vector<Image> table = s.shade(0, 0, judged);
  std::filesystem::remove(broken);
  const ComparisonLimits limits = integrated_limits();
  std::vector<ToleranceClass> tolerances = load_tolerances(std::filesystem::path(KILN_SOURCE_DIR) / "variants/scenes/render/tolerances.json");
  for (size_t i = 0; i < judged; ++i) {
    SCOPED_TRACE(variant_name(kVariants[i]));
    const bool linear = linear_output(kVariants[i]);
    Image rendered = s.renderer->render(s.pack.select("Forward", kVariants[i]));
    EXPECT_TRUE(compare_images(rendered, table[i], linear, limits_for(tolerances, kVariants[i])).passed)
        << "the table-sampling reference should share the wrong data and agree";
    Comparison c = compare_images(rendered, integrated[i], linear, limits);
    std::cout << "[ integrated ] wrong SH9, " << variant_name(kVariants[i]) << ": lavapipe " << describe(c) << "\n";
    EXPECT_FALSE(c.passed) << "the integrated reference missed a wrong SH9 band: " << describe(c);
  }
}

}  // namespace
}  // namespace kiln::render
