// SPDX-License-Identifier: Apache-2.0
// kiln test's image comparison and the scene features the adversarial scene needs, on synthetic images and
// matrices (no renderer): fractions are of the shaded pixels, the worst pixel is bounded, shadow-test ties are
// capped, object transforms rotate and scale, a scene can name the variants it judges.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <functional>
#include <numeric>

#include "golden/golden.hpp"
#include "scene/scene.hpp"
#include "scene/verify_error.hpp"

namespace kiln::render {
namespace {

constexpr uint32_t kSide = 100;

// A reference whose left `shaded_columns` columns hold geometry (alpha 1, grey 0.2), the rest background (alpha 0,
// black), and a rendered copy of it.
struct Images {
  Image reference{kSide, kSide, std::vector<float>(size_t(kSide) * kSide * 4, 0.0f)};
  Image rendered;
  explicit Images(uint32_t shaded_columns) {
    for (uint32_t y = 0; y < kSide; ++y)
      for (uint32_t x = 0; x < shaded_columns; ++x) {
        float* p = reference.pixel(x, y);
        p[0] = p[1] = p[2] = 0.2f;
        p[3] = 1;
      }
    rendered = reference;
  }
};

ComparisonLimits limits() {
  ComparisonLimits l;
  l.max_channel_difference = 2;
  l.max_fraction_over = 0.01;
  l.max_relative_rmse = 1.0;  // not what these tests judge
  l.max_worst_difference = 40;
  l.max_fraction_skipped = 0.005;
  return l;
}

TEST(Comparison, FractionsAreOfTheShadedPixelsSoTheBackgroundCannotDiluteThem) {
  Images im(25);  // 2,500 shaded pixels of 10,000
  for (uint32_t y = 0; y < 50; ++y) im.rendered.pixel(0, y)[0] = 0.25f;  // 50 pixels a few levels brighter in red
  Comparison c = compare_images(im.rendered, im.reference, true, limits());
  EXPECT_EQ(c.shaded, 2500u);
  EXPECT_EQ(c.over, 50u);
  EXPECT_DOUBLE_EQ(c.fraction_over, 0.02);  // over all 10,000 pixels it would have been 0.5%, under the limit
  EXPECT_FALSE(c.passed);
  EXPECT_NE(describe_comparison(c, limits()).find("over the limit: pixels over"), std::string::npos)
      << describe_comparison(c, limits());
}

TEST(Comparison, ABackgroundPixelTheShaderLitCountsAsOver) {
  Images im(25);
  im.rendered.pixel(90, 90)[1] = 1.0f;
  Comparison c = compare_images(im.rendered, im.reference, true, limits());
  EXPECT_EQ(c.over, 1u);
  EXPECT_GT(c.max_difference, 40);
  EXPECT_FALSE(c.passed) << describe_comparison(c, limits());
}

TEST(Comparison, OneWrongPixelFailsOnTheWorstPixelBoundEvenWhenTheFractionIsTiny) {
  Images im(100);
  im.rendered.pixel(3, 4)[2] = 0.6f;
  ComparisonLimits l = limits();
  Comparison c = compare_images(im.rendered, im.reference, true, l);
  EXPECT_EQ(c.over, 1u);
  EXPECT_LE(c.fraction_over, l.max_fraction_over);
  EXPECT_GT(c.max_difference, l.max_worst_difference);
  EXPECT_FALSE(c.passed);
  EXPECT_NE(describe_comparison(c, l).find("over the limit: worst pixel"), std::string::npos) << describe_comparison(c, l);
  l.max_worst_difference = 255;
  EXPECT_TRUE(compare_images(im.rendered, im.reference, true, l).passed);
}

TEST(Comparison, ShadowTieExclusionsAreCountedCappedAndReported) {
  Images im(50);  // 5,000 shaded pixels; the cap is 0.5% of them: 25
  for (uint32_t x = 0; x < 25; ++x) im.reference.pixel(x, 7)[3] = kUnstablePixel;
  Comparison c = compare_images(im.rendered, im.reference, true, limits());
  EXPECT_EQ(c.unstable, 25u);
  EXPECT_TRUE(c.passed) << describe_comparison(c, limits());
  EXPECT_NE(describe_comparison(c, limits()).find("tie pixels skipped (shadow test, coverage) 25 = 0.500% (limit 0.500%)"), std::string::npos)
      << describe_comparison(c, limits());
  im.reference.pixel(30, 7)[3] = kUnstablePixel;
  c = compare_images(im.rendered, im.reference, true, limits());
  EXPECT_FALSE(c.passed);
  EXPECT_NE(describe_comparison(c, limits()).find("over the limit: ties"), std::string::npos);
}

TEST(Comparison, TheSuitesToleranceFileStatesEveryLimitForEveryClass) {
  auto classes = load_tolerances(std::filesystem::path(KILN_SOURCE_DIR) / "variants/scenes/render/tolerances.json");
  ASSERT_FALSE(classes.empty());
  for (const ToleranceClass& c : classes) {
    SCOPED_TRACE(c.name);
    EXPECT_LT(c.max_worst_difference, 255) << "a class must bound its worst pixel";
    EXPECT_LT(c.max_fraction_skipped, 0.05) << "a class must cap its shadow-tie exclusions";
  }
  const std::filesystem::path missing = std::filesystem::temp_directory_path() / "kiln-tolerances-missing.json";
  std::ofstream(missing) << R"({"classes": [{"name": "x", "max_channel_difference": 2, "max_fraction_over": 0.001,
                                 "max_relative_rmse": 0.003, "reason": "no worst-pixel bound"}]})";
  EXPECT_ANY_THROW(load_tolerances(missing));
  std::filesystem::remove(missing);
}

TEST(Scene, ObjectsRotateAboutXThenYThenZAfterANonUniformScale) {
  Object o;
  o.size = 2;
  o.scale = {1, 3, 1};
  o.rotation_degrees = {90, 0, 0};
  o.position = {10, 0, 0};
  // (0, 1, 0) scales to (0, 6, 0); 90 degrees about x takes +y to +z.
  auto p = mat_apply(object_to_world(o), {0, 1, 0, 1});
  EXPECT_NEAR(p[0], 10, 1e-12);
  EXPECT_NEAR(p[1], 0, 1e-12);
  EXPECT_NEAR(p[2], 6, 1e-12);
  o.rotation_degrees = {90, 0, 90};  // then 90 degrees about z takes +z to +z and +x to +y
  p = mat_apply(object_to_world(o), {1, 0, 0, 0});
  EXPECT_NEAR(p[0], 0, 1e-12);
  EXPECT_NEAR(p[1], 2, 1e-12);
  EXPECT_NEAR(p[2], 0, 1e-12);
}

TEST(Scene, TheAdversarialSceneHasTransformedObjectsAndNamesTheVariantsItJudges) {
  Scene scene = load_scene(std::filesystem::path(KILN_SOURCE_DIR) / "variants/scenes/render/audit.json");
  bool non_uniform = false, rotated = false;
  for (const Object& o : scene.objects) {
    non_uniform |= o.scale[0] != o.scale[1] || o.scale[1] != o.scale[2];
    rotated |= o.rotation_degrees[0] != 0 || o.rotation_degrees[1] != 0 || o.rotation_degrees[2] != 0;
  }
  EXPECT_TRUE(non_uniform);
  EXPECT_TRUE(rotated);
  // Every Forward+ tile can hold 63 lights: the scene has exactly that many, so full tiles are reachable.
  EXPECT_EQ(scene.lights.size(), size_t(kMaxLightsPerTile));
  FrameSetup frame = setup_frame(scene, 1);
  size_t full = 0, tiles = size_t(frame.tiles_x) * frame.tiles_y;
  for (size_t t = 0; t < tiles; ++t) full += frame.tile_lists[t * kTileStride] == kMaxLightsPerTile;
  EXPECT_GT(full, tiles / 2) << full << " of " << tiles << " tiles hold 63 lights";
  EXPECT_TRUE(scene.judges("(none)"));
  EXPECT_TRUE(scene.judges("FOG_EXP _ADDITIONAL_LIGHTS _ADDITIONAL_LIGHT_SHADOWS _FORWARD_PLUS _MAIN_LIGHT_SHADOWS "
                           "_MULTISCATTER _SHADOWS_SOFT"));
  EXPECT_FALSE(scene.judges("_LINEAR_OUTPUT"));
  EXPECT_TRUE(load_scene(std::filesystem::path(KILN_SOURCE_DIR) / "variants/scenes/render/spheres.json").judges("_LINEAR_OUTPUT"));
}


// What no golden pixel ran before (issue 40): a reflection probe with box projection, its box holding the camera,
// and the ground in front of the camera inside the first shadow cascade's sphere.
TEST(Scene, TheAdversarialSceneHasABoxProjectedProbeAndTheFirstCascadeInView) {
  const std::filesystem::path file = std::filesystem::path(KILN_SOURCE_DIR) / "variants/scenes/render/audit.json";
  Scene scene = load_scene(file);
  ASSERT_TRUE(scene.probe.box_projection);
  for (int a = 0; a < 3; ++a) {
    EXPECT_LT(scene.probe.box_min[a], scene.camera_position[a]);
    EXPECT_GT(scene.probe.box_max[a], scene.camera_position[a]);
  }
  // The ray through the bottom edge of the view, where it meets the ground (y = 0).
  FrameSetup frame = setup_frame(scene, cascades_for({"_MAIN_LIGHT_SHADOWS_CASCADE"}, scene));
  const Vec3 f = frame.camera_forward;
  Vec3 right{-f[2], 0, f[0]};  // forward x up(0, 1, 0)
  const double r = std::sqrt(right[0] * right[0] + right[2] * right[2]);
  right = {right[0] / r, 0, right[2] / r};
  const Vec3 up{right[1] * f[2] - right[2] * f[1], right[2] * f[0] - right[0] * f[2], right[0] * f[1] - right[1] * f[0]};
  const double down = std::tan(scene.vertical_fov_degrees * 3.14159265358979 / 360);
  const Vec3 d{f[0] - up[0] * down, f[1] - up[1] * down, f[2] - up[2] * down};
  ASSERT_LT(d[1], 0);
  const double t = -scene.camera_position[1] / d[1];
  const auto& sphere = frame.cascade_spheres[0];
  double distance2 = 0;
  for (int a = 0; a < 3; ++a) distance2 += std::pow(scene.camera_position[a] + d[a] * t - sphere[a], 2);
  EXPECT_LT(distance2, sphere[3]) << "the nearest visible ground is outside cascade 0";

  // A probe outside its box is the scene's error, named.
  std::ifstream in(file);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string box_max = "\"box_max\": [3.5, 3.5, 5.5]";
  ASSERT_NE(text.find(box_max), std::string::npos);
  text.replace(text.find(box_max), box_max.size(), "\"box_max\": [3.5, 3.5, 0.25]");
  const std::filesystem::path bad = std::filesystem::temp_directory_path() / "kiln-scene-probe-outside-its-box.json";
  std::ofstream(bad) << text;
  try {
    load_scene(bad);
    ADD_FAILURE() << "a probe outside its box was accepted";
  } catch (const VerifyError& e) {
    EXPECT_EQ(e.diagnostic().id, DiagId::RenderScene);
    EXPECT_NE(std::string(e.what()).find("'position' inside the box"), std::string::npos) << e.what();
  }
  // A box too large to be a number is refused before the probe is read: the scene's JSON parse stops at 1e999.
  const std::string outside = "\"box_max\": [3.5, 3.5, 0.25]";
  text.replace(text.find(outside), outside.size(), "\"box_max\": [3.5, 3.5, 1e999]");
  std::ofstream(bad) << text;
  try {
    load_scene(bad);
    ADD_FAILURE() << "an infinite box was accepted";
  } catch (const VerifyError& e) {
    EXPECT_EQ(e.diagnostic().id, DiagId::RenderScene);
    EXPECT_NE(std::string(e.what()).find("number overflow"), std::string::npos) << e.what();
  }
  std::filesystem::remove(bad);
}

// kiln test --cover: every combination of `strength` values some row holds is held by a chosen row.
bool covers(const std::vector<std::vector<uint32_t>>& rows, const std::vector<size_t>& chosen, unsigned strength) {
  const size_t groups = rows.front().size();
  std::vector<uint32_t> subset(strength);
  std::function<bool(size_t, size_t)> each = [&](size_t depth, size_t from) {
    if (depth == strength) {
      for (const auto& row : rows) {
        bool held = std::any_of(chosen.begin(), chosen.end(), [&](size_t c) {
          return std::all_of(subset.begin(), subset.end(), [&](uint32_t g) { return rows[c][g] == row[g]; });
        });
        if (!held) return false;
      }
      return true;
    }
    for (size_t g = from; g < groups; ++g) {
      subset[depth] = uint32_t(g);
      if (!each(depth + 1, g + 1)) return false;
    }
    return true;
  };
  return each(0, 0);
}

TEST(CoveringSample, HoldsEveryCombinationOfStrengthValuesInFewRowsTheSameOnEveryRun) {
  // Every row of 2 x 3 x 2 x 2 x 4 x 2 x 2 x 2 values, less the rows a constraint drops (group 1's third value
  // only with group 0's second), in a fixed scrambled order, as a pack's expansion would leave them.
  const std::vector<uint32_t> sizes{2, 3, 2, 2, 4, 2, 2, 2};
  std::vector<std::vector<uint32_t>> rows;
  for (uint32_t n = 0; n < 2 * 3 * 2 * 2 * 4 * 2 * 2 * 2; ++n) {
    std::vector<uint32_t> row;
    for (uint32_t k = n, g = 0; g < sizes.size(); k /= sizes[g], ++g) row.push_back(k % sizes[g]);
    if (row[1] == 2 && row[0] != 1) continue;
    rows.push_back(row);
  }
  std::vector<std::vector<uint32_t>> scrambled;
  for (size_t i = 0; i < rows.size(); ++i) scrambled.push_back(rows[(i * 37) % rows.size()]);
  ASSERT_EQ(std::gcd(size_t(37), rows.size()), 1u);
  for (unsigned strength : {1u, 2u, 3u}) {
    const std::vector<size_t> chosen = covering_sample(scrambled, strength);
    EXPECT_TRUE(covers(scrambled, chosen, strength)) << "strength " << strength;
    EXPECT_TRUE(std::is_sorted(chosen.begin(), chosen.end()));
    EXPECT_EQ(chosen, covering_sample(scrambled, strength));
    // The fewest rows possible are the product of the `strength` largest groups (4, 3, 2 values); greedy stays
    // close to it and far below the whole.
    const size_t floor = strength == 1 ? 4 : strength == 2 ? 12 : 24;
    EXPECT_GE(chosen.size(), floor) << "strength " << strength;
    EXPECT_LE(chosen.size(), floor * 2) << "strength " << strength;
  }
  // A combination only a constrained row holds is still covered: (group 0 second value, group 1 third value).
  const std::vector<size_t> pairs = covering_sample(scrambled, 2);
  EXPECT_TRUE(std::any_of(pairs.begin(), pairs.end(), [&](size_t c) { return scrambled[c][0] == 1 && scrambled[c][1] == 2; }));
  // Strength 0, or as many as there are groups: every distinct row.
  EXPECT_EQ(covering_sample(scrambled, 0).size(), scrambled.size());
  EXPECT_EQ(covering_sample(scrambled, 8).size(), scrambled.size());
  EXPECT_THROW(covering_sample(scrambled, 5), std::invalid_argument);
  // A hostile pack: 400 two-valued groups at strength 4 would be 1.06e9 combinations of groups per variant.
  const std::vector<std::vector<uint32_t>> wide(10, std::vector<uint32_t>(400, 1));
  EXPECT_THROW(covering_sample(wide, 4), std::invalid_argument);
  EXPECT_EQ(covering_sample(wide, 1).size(), 1u);
}

}  // namespace
}  // namespace kiln::render
