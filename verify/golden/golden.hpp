// SPDX-License-Identifier: Apache-2.0
// `kiln test`: renders every Forward variant of a pack and compares each image with the reference image
// the CPU reference computed for it (a golden directory written by `kiln-reference goldens`), under the
// limits of a tolerance file. Prints one line per variant (metric, measured value, limit); on a failure
// writes the rendered, reference and difference images and an HTML page showing them side by side.
#pragma once

#include <filesystem>
#include <iosfwd>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "kiln/pack_reader.hpp"
#include "kiln/manifest_json.hpp"
#include "render/backend.hpp"
#include "scene/image.hpp"
#include "scene/verify_error.hpp"

namespace kiln::render {


// Limits for a class of variants; a variant is held to the loosest limits of every class it matches.
struct ToleranceClass {
  std::string name;
  std::vector<std::string> when_any;  // keywords; empty: every variant
  std::vector<std::string> when_all;  // and all of these
  std::vector<std::string> scenes;    // render scene names (Scene::name); empty: every scene
  int max_channel_difference = 2;     // of 255, on the display-encoded (ACES, sRGB, 8-bit) image
  double max_fraction_over = 0.001;   // of the shaded pixels, those with a channel over that difference
  double max_relative_rmse = 1e-3;    // on the shader's float output, RGB
  int max_worst_difference = 255;     // of 255: the largest channel difference any pixel may have
  double max_fraction_skipped = 0;    // of the shaded pixels, the shadow-test ties skipped
  std::string reason;
};
std::vector<ToleranceClass> load_tolerances(const std::filesystem::path& path);

struct ComparisonLimits {
  int max_channel_difference = 0;
  double max_fraction_over = 0;
  double max_relative_rmse = 0;
  int max_worst_difference = 0;
  double max_fraction_skipped = 0;
  std::vector<std::string> classes;
};
ComparisonLimits limits_for(const std::vector<ToleranceClass>& classes, const std::vector<std::string>& keywords,
                            const std::string& scene = "");

// Fractions are of the shaded pixels: those the reference covers with geometry (alpha not 0). The background
// is not counted in the denominator, so it cannot dilute an error; a background pixel that differs still counts
// as over (and in the worst difference).
struct Comparison {
  size_t shaded = 0;            // pixels with geometry in the reference
  size_t over = 0;              // compared pixels with a channel difference over the limit
  double fraction_over = 0;     // over / shaded
  int max_difference = 0;       // largest 8-bit channel difference of any compared pixel
  double relative_rmse = 0;
  size_t non_finite = 0;        // NaN or Inf values in the rendered image
  size_t unstable = 0;          // pixels the reference marked kUnstablePixel (not compared)
  double fraction_skipped = 0;  // unstable / shaded
  bool passed = false;
};
// `linear_output`: the images hold linear radiance (_LINEAR_OUTPUT); both are tone-mapped for display.
// Passes when nothing is NaN/Inf and each of the four measures is within its limit.
Comparison compare_images(const Image& rendered, const Image& reference, bool linear_output, const ComparisonLimits& limits);
// One line: each measure against its limit, e.g. "pixels over 2/255 0.031% of 40321 shaded (limit 0.100%), ...".
std::string describe_comparison(const Comparison& c, const ComparisonLimits& limits);

// Writes <dir>/<stem>.render.png, .reference.png, .diff.png (|difference| x 16) and returns the HTML row.
std::string write_failure_images(const std::filesystem::path& dir, const std::string& stem, const Image& rendered,
                                 const Image& reference, bool linear_output, const std::string& title,
                                 const std::string& details);
void write_html_report(const std::filesystem::path& path, const std::string& title, const std::vector<std::string>& rows,
                       const std::string& rendered_by = "lavapipe", const std::string& compared_with = "CPU reference");

}  // namespace kiln::render

namespace kiln::render {

struct GoldenTestOptions {
  std::filesystem::path pack_dir;
  std::filesystem::path scene;
  std::filesystem::path golden_dir;   // index.json + reference images (kiln-reference goldens)
  std::filesystem::path tolerances;
  std::filesystem::path report_dir;   // failures: images + index.html
  std::string filter;                 // only variants whose keyword list contains this text
  std::string api = "vulkan";         // vulkan, gl or gles (render/backend.hpp)
  // Another API: compare each image with that API's image of the same variant instead of the reference image
  // (same limits; the reference still marks the shadow-tie pixels).
  std::string against;
  // Shard I of N: every N-th distinct pipeline (pair of modules for the API, in first-use order) with all the
  // variants that share it, so that a pipeline is compiled in one shard only.
  unsigned shard_index = 0, shard_count = 1;
  // 0: every variant. N (1-4): only a strength-N covering sample of the variants (covering_sample), then sharded.
  unsigned cover = 0;
  // When set: the run records its selections in this usage log (docs/usage.md) as a game would, tagged with the
  // scene and the API: each Forward variant it judges, selected by its keywords, and the ShadowCaster variants.
  std::filesystem::path usage_log;
  // When set (a --coverage pack): the HLSL lines the run's draws executed, as an lcov tracefile here (test name: the
  // scene), and as JSON with the first scene and variant that lit each line at `coverage_json` when that is set too.
  std::filesystem::path coverage, coverage_json;
};

struct GoldenTestSummary {
  size_t passed = 0;
  size_t failed = 0;
  size_t not_run = 0;  // counted as failures: a skipped variant is never a pass
  double seconds = 0;
  // The worst exit status among the variants that could not be rendered (diagnostics.def's classes; 0 when none).
  int worst_exit_status = 0;
  bool ok() const { return failed == 0 && not_run == 0 && passed > 0; }
  // kiln test's exit status: a failed or unrendered variant is 1, unless the reason it was not rendered is worse.
  int exit_status() const { return worse_exit_status(ok() ? 0 : 1, worst_exit_status); }
};

// The Forward variants shard `shard_index` of `shard_count` runs, in the order it runs them: grouped by
// pipeline (the vertex and fragment modules for `api`, compared byte for byte), pipelines in first-use order,
// every N-th pipeline; the shards of one N cover every variant exactly once.
// With `cover` N > 0, only the variants of covering_variants(pack, "Forward", N) are grouped and sharded.
std::vector<size_t> variants_to_run(const PackReader& pack, Api api, unsigned shard_index, unsigned shard_count,
                                    unsigned cover = 0);

// A covering sample (combinatorial testing's covering array, taken from the rows that exist): `rows` holds one
// row per variant, the index of its value in each keyword group. The result is a small set of row indices, in
// ascending order, such that every combination of `strength` values from `strength` different groups that some
// row has is also in a chosen row; chosen greedily (the row that covers the most combinations not yet covered,
// the lowest index on a tie), so about logarithmically more rows than the fewest possible, and the same rows on
// every run. Strength 0, or at least the number of groups, chooses every distinct row; otherwise it is at most 4.
// A pack whose C(groups, strength) x variants exceeds kMaxCoveringWork is refused (std::invalid_argument).
inline constexpr double kMaxCoveringWork = 5e7;
std::vector<size_t> covering_sample(const std::vector<std::vector<uint32_t>>& rows, unsigned strength);
// The Forward (or other) pass's variants as covering_sample rows: each variant's value in each keyword group.
std::vector<size_t> covering_variants(const PackReader& pack, std::string_view pass, unsigned strength);

// Every Forward variant of the pack (of the shard), rendered with the scene and compared with its golden.
GoldenTestSummary run_golden_test(const GoldenTestOptions& options, std::ostream& out);


}  // namespace kiln::render
