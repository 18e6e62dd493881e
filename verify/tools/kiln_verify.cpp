// SPDX-License-Identifier: Apache-2.0
// kiln-verify: renders packs and compares them with the CPU reference's goldens (`kiln render`, `kiln test`;
// kiln hands these verbs to this executable). Everything here links Vulkan, EGL, PNG and OpenEXR; the compiler
// does not.
#include <CLI/CLI.hpp>
#include <malloc.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "golden/golden.hpp"
#include "kiln/guarded_main.hpp"
#ifdef KILN_FAULT_INJECTION
#include "fault_injection.hpp"
#endif
#include "kiln/pack_reader.hpp"
#include "kiln/manifest_json.hpp"
#include "render/backend.hpp"
#include "scene/image.hpp"
#include "scene/verify_error.hpp"
#include "tools/draw_cost.hpp"
#include "tools/render_watch.hpp"

namespace {

std::string format_ms(double ms) {
  char text[32];
  if (ms >= 1000) std::snprintf(text, sizeof text, "%.2f s", ms / 1000);
  else std::snprintf(text, sizeof text, "%.1f ms", ms);
  return text;
}

std::vector<std::string> split_words(const std::string& text) {
  std::vector<std::string> words;
  std::istringstream in(text);
  for (std::string w; in >> w;) words.push_back(w);
  return words;
}

int run_render(const std::string& pack_dir, const std::string& pass, const std::string& keywords,
               const std::string& scene_file, const std::string& png_out, const std::string& exr_out,
               const std::string& size_text, const std::string& api, const std::string& coverage_out, bool watch) {
  return kiln::render::reporting_errors([&] {
    uint32_t width = 0, height = 0;
    if (!size_text.empty() && std::sscanf(size_text.c_str(), "%ux%u", &width, &height) != 2)
      kiln::render::fail(kiln::DiagId::VerifyArgument, {}, "--size wants WxH, e.g. 256x256 (got '" + size_text + "')");
    if (watch && !coverage_out.empty())
      kiln::render::fail(kiln::DiagId::VerifyArgument, {}, "--watch and --coverage do not go together (a tracefile is one run's)");
    // Before the device starts its threads: they inherit the mask, so SIGINT and SIGTERM reach only the signalfd.
    const int signal_fd = watch ? kiln::render::block_stop_signals() : -1;
    if (watch && signal_fd < 0) {
      std::cerr << "kiln: error: cannot wait for signals: signalfd: " << std::strerror(errno) << "\n";
      return 3;
    }
    kiln::PackReader pack = kiln::PackReader::open(pack_dir);
    kiln::render::Scene scene = kiln::render::load_scene(scene_file);
    auto renderer = kiln::render::Backend::open(kiln::render::parse_api(api), pack, scene, width, height);
    std::unique_ptr<kiln::render::CoverageRecorder> coverage;
    // Selects the variant from the pack served now, draws it and writes the images (each atomically: a viewer or a
    // test never reads half a frame).
    auto draw = [&](double& ms) {
      kiln::SelectedVariant variant = pack.select(pass, split_words(keywords));
      if (!coverage_out.empty() && !coverage) {
        coverage = std::make_unique<kiln::render::CoverageRecorder>(pack, pack_dir);
        coverage->set_witness(scene.name + " " + pass + " " + kiln::render::variant_name(variant.keywords));
        renderer->record_coverage(coverage.get());
      }
      auto start = std::chrono::steady_clock::now();
      kiln::render::Image image = renderer->render(variant);
      ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
      bool linear = std::find(variant.keywords.begin(), variant.keywords.end(), "_LINEAR_OUTPUT") != variant.keywords.end();
      kiln::render::write_png(png_out, image.width, image.height, kiln::render::encode_srgb8(image, linear));
      if (!exr_out.empty()) {
        // .kimg: kiln's raw float image (scene/image.hpp), read by tests without an EXR library.
        if (exr_out.ends_with(".kimg")) kiln::render::write_kimg(exr_out, image);
        else kiln::render::write_exr(exr_out, image);
      }
      return std::make_pair(std::move(variant.keywords), std::move(image));
    };
    double ms = 0;
    auto [drawn, image] = draw(ms);
    std::cout << "kiln render: " << png_out << " (" << image.width << "x" << image.height << ", variant "
              << kiln::render::variant_name(drawn) << ", " << renderer->device() << ", " << format_ms(ms)
              << " including shader compilation)\n";
    if (coverage) {
      coverage->write_lcov(coverage_out, scene.name);
      std::cout << "kiln render: " << coverage->summary() << "; lcov tracefile " << coverage_out << "\n";
    }
    if (!watch) return 0;
    kiln::render::WatchedFrame frame{pass, split_words(keywords), drawn, png_out};
    return kiln::render::redraw_on_update(pack, *renderer, signal_fd, std::move(frame), [&] {
      double redraw_ms = 0;
      return draw(redraw_ms).first;
    }, std::cout);
  });
}

int run_test(const std::string& pack_dir, const std::string& scene_file, const std::string& golden_dir,
             const std::string& tolerances, const std::string& report_dir, const std::string& filter,
             const std::string& shard, const std::string& api, const std::string& against, unsigned cover,
             const std::string& usage_log, const std::string& coverage, const std::string& coverage_json) {
  kiln::render::GoldenTestOptions options;
  options.pack_dir = pack_dir;
  options.scene = scene_file;
  options.golden_dir = golden_dir;
  options.tolerances = tolerances;
  options.report_dir = report_dir;
  options.filter = filter;
  options.api = api;
  options.against = against;
  options.cover = cover;
  options.usage_log = usage_log;
  options.coverage = coverage;
  options.coverage_json = coverage_json;
  return kiln::render::reporting_errors([&] {
    if (!shard.empty() && (std::sscanf(shard.c_str(), "%u/%u", &options.shard_index, &options.shard_count) != 2 ||
                           options.shard_count == 0 || options.shard_index >= options.shard_count))
      kiln::render::fail(kiln::DiagId::VerifyArgument, {}, "--shard wants I/N with I < N (got '" + shard + "')");
    return kiln::render::run_golden_test(options, std::cout).exit_status();
  });
}

// lavapipe and llvmpipe allocate and free megabytes per pipeline and per draw (shader code, tile and vertex
// buffers), and so does every image a test compares. glibc's defaults hand those blocks back to the kernel
// (mmap above an adaptive threshold, heap trimming above 128 KiB free) and fault them in again, zeroed, on
// the next variant: a quarter of a cold Vulkan kiln test went to page faults. Keep them in the heap; the
// process lives for one test run. Measured in bench/REPORT.md, "Golden verification time".
void keep_freed_memory_in_the_heap() {
  mallopt(M_MMAP_THRESHOLD, 32 << 20);  // 64 and 256 MiB measured the same
  mallopt(M_TRIM_THRESHOLD, 512 << 20);
}

// llvmpipe and lavapipe compile each pipeline for a few draws: LLVM's IR passes (on by default) cost more than
// they save, and leaving them out changes no bit of an image (golden.determinism_and_cross_variant checks it on
// each API). A caller's own GALLIVM_PERF, even an empty one, is kept.
void default_driver_settings() { setenv("GALLIVM_PERF", "nopt", /*overwrite=*/0); }

int run(int argc, char** argv) {
  keep_freed_memory_in_the_heap();
  default_driver_settings();
  CLI::App app{"kiln-verify: renders variant packs on Mesa lavapipe/llvmpipe and compares them with CPU-reference goldens", "kiln"};
  app.require_subcommand(1);
  std::string pack_dir, scene_file;
  std::string variant_keywords, png_out, exr_out, size_text, golden_dir, tolerances, report_dir, filter, shard;
  std::string api = "vulkan";
  const char* api_help = "vulkan (SPIR-V on lavapipe), gl (GLSL 450 on llvmpipe OpenGL 4.5) or gles (GLSL ES on llvmpipe OpenGL ES 3.2)";
  CLI::App* render = app.add_subcommand("render", "Render a scene with one Forward variant of a pack (lavapipe or llvmpipe GL)");
  render->add_option("pack_dir", pack_dir, "Directory holding a pack (or its manifest)")->required();
  render->add_option("--variant", variant_keywords, "The variant's keywords, space-separated (selection rules: docs/design.md)");
  render->add_option("--scene", scene_file, "Render scene (variants/scenes/render/*.json)")->required()->check(CLI::ExistingFile);
  render->add_option("-o,--output", png_out, "PNG output (8-bit sRGB, tone-mapped)")->required();
  render->add_option("--exr", exr_out, "Also write the float image (OpenEXR, 32-bit; a .kimg name writes kiln's raw float format)");
  render->add_option("--size", size_text, "Image size WxH (default: the scene's)");
  render->add_option("--api", api, api_help)->check(CLI::IsMember({"vulkan", "gl", "gles"}));
  std::string pass = "Forward", render_coverage;
  render->add_option("--pass", pass, "The pass that draws the image: Forward (the default), or one that reads only the frame, "
                                     "material and object constants (DepthOnly, DepthNormals)");
  render->add_option("--coverage", render_coverage, "Write the HLSL lines the render executed as an lcov tracefile (a pack built with "
                                                    "kiln build --coverage: docs/coverage.md)");
  bool render_watch = false;
  render->add_flag("--watch", render_watch, "Keep running: draw the image again each time the pack is replaced (kiln watch, "
                                            "kiln build), one line each, until SIGINT or SIGTERM (docs/development-loop.md)");

  CLI::App* test = app.add_subcommand("test", "Render every Forward variant and compare it with its CPU-reference golden");
  test->add_option("pack_dir", pack_dir, "Directory holding a pack (or its manifest)")->required();
  test->add_option("--scene", scene_file, "Render scene")->required()->check(CLI::ExistingFile);
  test->add_option("--golden", golden_dir, "Golden directory (kiln-reference goldens)")->required();
  test->add_option("--tolerances", tolerances, "Tolerance classes (JSON)")->required()->check(CLI::ExistingFile);
  test->add_option("--report", report_dir, "Directory for failure images and index.html");
  test->add_option("--filter", filter, "Only variants whose keyword list contains this text");
  test->add_option("--shard", shard, "I/N: run every N-th distinct pipeline (with all the variants that share it) starting at I");
  test->add_option("--api", api, api_help)->check(CLI::IsMember({"vulkan", "gl", "gles"}));
  unsigned cover = 0;
  test->add_option("--cover", cover,
                   "N (1-4): only a strength-N covering sample: the few variants that together hold every combination of "
                   "N keyword values some variant holds (a quick check across APIs; default: every variant)")
      ->check(CLI::Range(1u, 4u));
  std::string usage_log;
  test->add_option("--usage-log", usage_log,
                   "Record the run's selections in this usage log, as a game would (docs/usage.md): the variants judged, "
                   "selected by their keywords, and the shadow casters");
  std::string coverage, coverage_json;
  test->add_option("--coverage", coverage,
                   "Write the HLSL lines the run executed as an lcov tracefile (a pack built with kiln build --coverage; "
                   "genhtml renders it: docs/coverage.md)");
  test->add_option("--coverage-json", coverage_json, "With --coverage: also each line's hits and the first scene and variant that lit it, as JSON");
  std::string against;
  test->add_option("--against", against, "Compare with this API's image of each variant instead of the reference image")
      ->check(CLI::IsMember({"vulkan", "gl", "gles"}));

  // kiln fold-cost's run-time half (draw_cost.cpp): not a verb of kiln's own, so not in its --help.
  CLI::App* draw_cost = app.add_subcommand("draw-cost", "Time the same variants drawn from differently folded packs (kiln fold-cost)");
  std::string draw_config, draw_out;
  draw_cost->add_option("config", draw_config, "Configuration (JSON: scene, frames, rounds, packs, rows)")->required();
  draw_cost->add_option("out", draw_out, "Result (JSON)")->required();

  app.failure_message([](const CLI::App*, const CLI::Error& error) {
    return std::string("kiln: error: ") + error.what() + "\nRun with --help for more information.\n";
  });
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& error) {
    return app.exit(error) == 0 ? 0 : 1;
  }
#ifdef KILN_FAULT_INJECTION  // the tests' kiln-verify-fault only (tests/support/fault_injection.hpp)
  kiln::testing::inject_fault(*render ? "render" : "test");
#endif
  if (*draw_cost) return kiln::render::run_draw_cost(draw_config, draw_out);
  if (*render) return run_render(pack_dir, pass, variant_keywords, scene_file, png_out, exr_out, size_text, api, render_coverage,
                                  render_watch);
  return run_test(pack_dir, scene_file, golden_dir, tolerances, report_dir, filter, shard, api, against, cover, usage_log,
                  coverage, coverage_json);
}

}  // namespace

// The guarded entry point (kiln/guarded_main.hpp): an exception that escapes is an internal error, exit 2. The
// renderer's and the reader's errors are the verbs' own (reporting_errors): exit 1, 3 or 2 by their class.
int main(int argc, char** argv) { return kiln::run_guarded([&] { return run(argc, argv); }); }
