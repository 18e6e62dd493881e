// SPDX-License-Identifier: Apache-2.0
// Every variant's GLSL 450 and GLSL ES 3.10 output, compiled and linked by a real OpenGL driver (Mesa llvmpipe,
// OpenGL 4.5 core and OpenGL ES 3.2 through EGL's surfaceless platform): the GL targets are accepted by a
// driver, not only produced. The Forward pass is left to the golden tests (`ctest -L golden`, golden.gl.* and
// golden.gles.*), which compile, link and draw every Forward variant's GL outputs and compare the images with
// the CPU reference; this test covers the other passes' variants, and the Forward pass with one program.
#include <gtest/gtest.h>

#include <map>
#include <set>

#include "kiln/pack_reader.hpp"
#include "render/gl_context.hpp"
#include "test_support.hpp"

namespace kiln {
namespace {

// The default pack as golden.setup built it (ctest fixture `golden`; building it again here would cost a
// cold build of every variant on CI).
class GlDrivers : public ::testing::Test {
 public:
  static void SetUpTestSuite() { built_ = std::filesystem::exists(pack_dir()); }
  static std::filesystem::path pack_dir() { return std::filesystem::path(KILN_GOLDEN_WORK) / "packs/lit"; }

  struct Outcome {
    size_t programs = 0;
    std::vector<std::string> failures;  // "pass [keywords]: log"
    std::set<std::string> failing_keywords;
  };

  // Compiles and links each distinct (vertex, fragment) source pair of every variant, except the Forward pass
  // beyond its first variant (drawn by the golden tests).
  static Outcome run(render::GlContext& driver, bool gles) {
    Outcome outcome;
    PackReader pack = PackReader::open(pack_dir());
    std::map<std::pair<std::string_view, std::string_view>, bool> seen;
    for (const std::string& pass : pack.passes())
      for (size_t i = 0; i < (pass == "Forward" ? 1 : pack.variant_count(pass)); ++i) {
        SelectedVariant v = pack.variant(pass, i);
        const StageView* vs = v.stage("vertex");
        const StageView* fs = v.stage("fragment");
        if (!vs || !fs) continue;
        std::string_view vertex = gles ? vs->gles : vs->glsl;
        std::string_view fragment = gles ? fs->gles : fs->glsl;
        if (!seen.emplace(std::pair{vertex, fragment}, true).second) continue;
        ++outcome.programs;
        std::string log;
        if (unsigned program = driver.compile_and_link(std::string(vertex), std::string(fragment), log)) {
          driver.gl().DeleteProgram(program);
        } else {
          std::string keywords;
          for (const auto& k : v.keywords) keywords += (keywords.empty() ? "" : " ") + k;
          outcome.failures.push_back(pass + " [" + keywords + "]: " + log);
          outcome.failing_keywords.insert(v.keywords.begin(), v.keywords.end());
        }
      }
    return outcome;
  }

  static bool built_;
};

bool GlDrivers::built_ = false;

// Every variant compiles and links, the explicit-fp16 (_HALF_PRECISION) ones included: kiln widens their 16-bit
// floats to mediump 32-bit floats for GL (compiler/src/cross/widen_float16.hpp), because SPIRV-Cross would
// otherwise require GL_AMD_gpu_shader_half_float or GL_NV_gpu_shader5, which llvmpipe (like most GL drivers)
// lacks.
void expect_every_program_links(render::GlApi api, bool gles) {
  auto opened = render::GlContext::open(api);
  ASSERT_TRUE(opened) << opened.error().message;
  auto driver = std::move(*opened);
  GlDrivers::Outcome outcome = GlDrivers::run(*driver, gles);
  EXPECT_GT(outcome.programs, 3u);  // Forward (one), ShadowCaster (two), DepthOnly, DepthNormals
  EXPECT_TRUE(outcome.failures.empty()) << outcome.failures.size() << " of " << outcome.programs << " failed on "
                                        << driver->renderer() << "; first: " << outcome.failures.front();
  EXPECT_TRUE(outcome.failing_keywords.empty());
  std::cout << (gles ? "GLSL ES: " : "GLSL 450: ") << outcome.programs << " programs linked on " << driver->renderer()
            << "\n";
}

TEST_F(GlDrivers, UndrawnPassesGlsl450CompilesAndLinksOnOpenGl45) {
  ASSERT_TRUE(built_);
  expect_every_program_links(render::GlApi::DesktopGl45, false);
}

TEST_F(GlDrivers, UndrawnPassesGlslEsCompilesAndLinksOnOpenGlEs32) {
  ASSERT_TRUE(built_);
  expect_every_program_links(render::GlApi::Gles32, true);
}

}  // namespace
}  // namespace kiln
