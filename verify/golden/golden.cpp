// SPDX-License-Identifier: Apache-2.0
#include "golden/golden.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <numeric>
#include <queue>
#include <set>
#include <stdexcept>

namespace kiln::render {

std::vector<ToleranceClass> load_tolerances(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) fail(DiagId::ToleranceFile, path, "cannot open the tolerance file");
  const nlohmann::json j = parse_json_file(in, path, DiagId::ToleranceFile);
  std::vector<ToleranceClass> classes;
  try {
    for (const auto& c : j.at("classes")) {
      ToleranceClass t;
      t.name = c.at("name").get<std::string>();
      t.when_any = c.value("when_any", std::vector<std::string>{});
      t.when_all = c.value("when_all", std::vector<std::string>{});
      t.scenes = c.value("scenes", std::vector<std::string>{});
      t.max_channel_difference = c.at("max_channel_difference").get<int>();
      t.max_fraction_over = c.at("max_fraction_over").get<double>();
      t.max_relative_rmse = c.at("max_relative_rmse").get<double>();
      t.max_worst_difference = c.at("max_worst_difference").get<int>();
      t.max_fraction_skipped = c.at("max_fraction_skipped").get<double>();
      t.reason = c.value("reason", "");
      if (t.reason.empty()) fail(DiagId::ToleranceFile, path, "class '" + t.name + "' states no reason");
      classes.push_back(t);
    }
  } catch (const nlohmann::json::exception& e) {
    fail(DiagId::ToleranceFile, path, std::string("a tolerance class is malformed: ") + e.what());
  }
  if (classes.empty()) fail(DiagId::ToleranceFile, path, "no tolerance classes");
  return classes;
}

ComparisonLimits limits_for(const std::vector<ToleranceClass>& classes, const std::vector<std::string>& keywords,
                            const std::string& scene) {
  ComparisonLimits limits;
  for (const ToleranceClass& c : classes) {
    auto present = [&](const std::string& k) { return std::find(keywords.begin(), keywords.end(), k) != keywords.end(); };
    bool matches = c.when_any.empty() || std::any_of(c.when_any.begin(), c.when_any.end(), present);
    matches = matches && std::all_of(c.when_all.begin(), c.when_all.end(), present);
    matches = matches && (c.scenes.empty() || std::find(c.scenes.begin(), c.scenes.end(), scene) != c.scenes.end());
    if (!matches) continue;
    limits.classes.push_back(c.name);
    limits.max_channel_difference = std::max(limits.max_channel_difference, c.max_channel_difference);
    limits.max_fraction_over = std::max(limits.max_fraction_over, c.max_fraction_over);
    limits.max_relative_rmse = std::max(limits.max_relative_rmse, c.max_relative_rmse);
    limits.max_worst_difference = std::max(limits.max_worst_difference, c.max_worst_difference);
    limits.max_fraction_skipped = std::max(limits.max_fraction_skipped, c.max_fraction_skipped);
  }
  return limits;
}

Comparison compare_images(const Image& rendered, const Image& reference, bool linear_output,
                          const ComparisonLimits& limits) {
  if (rendered.width != reference.width || rendered.height != reference.height)
    fail(DiagId::GoldenData, {}, "image sizes differ: rendered " + std::to_string(rendered.width) + "x" +
                             std::to_string(rendered.height) + ", reference " + std::to_string(reference.width) + "x" +
                             std::to_string(reference.height));
  Comparison c;
  std::vector<uint8_t> a = encode_srgb8(rendered, linear_output), b = encode_srgb8(reference, linear_output);
  size_t pixels = size_t(rendered.width) * rendered.height;
  double error = 0, energy = 0;
  for (size_t p = 0; p < pixels; ++p) {
    const float coverage = reference.rgba[p * 4 + 3];
    if (coverage != 0) ++c.shaded;
    if (coverage == kUnstablePixel) {
      ++c.unstable;
      continue;
    }
    int worst = 0;
    for (int ch = 0; ch < 3; ++ch) {
      worst = std::max(worst, std::abs(int(a[p * 4 + ch]) - int(b[p * 4 + ch])));
      double r = rendered.rgba[p * 4 + ch], g = reference.rgba[p * 4 + ch];
      if (!std::isfinite(r)) {
        ++c.non_finite;
        continue;
      }
      error += (r - g) * (r - g);
      energy += g * g;
    }
    c.max_difference = std::max(c.max_difference, worst);
    if (worst > limits.max_channel_difference) ++c.over;
  }
  // An image without geometry judges nothing but its background: any pixel over is then a failure.
  auto fraction = [&](size_t n) { return c.shaded ? double(n) / double(c.shaded) : n ? 1.0 : 0.0; };
  c.fraction_over = fraction(c.over);
  c.fraction_skipped = fraction(c.unstable);
  c.relative_rmse = energy > 0 ? std::sqrt(error / energy) : std::sqrt(error);
  c.passed = c.non_finite == 0 && c.fraction_over <= limits.max_fraction_over &&
             c.relative_rmse <= limits.max_relative_rmse && c.max_difference <= limits.max_worst_difference &&
             c.fraction_skipped <= limits.max_fraction_skipped;
  return c;
}

namespace {

std::string format(const char* fmt, double value) {
  char text[64];
  std::snprintf(text, sizeof text, fmt, value);
  return text;
}

std::string exceeded_measures(const Comparison& c, const ComparisonLimits& limits) {
  std::string names;
  auto add = [&](bool exceeded, const char* name) {
    if (exceeded) names += (names.empty() ? "" : ", ") + std::string(name);
  };
  add(c.non_finite != 0, "NaN/Inf");
  add(c.fraction_over > limits.max_fraction_over, "pixels over");
  add(c.max_difference > limits.max_worst_difference, "worst pixel");
  add(c.relative_rmse > limits.max_relative_rmse, "RMSE");
  add(c.fraction_skipped > limits.max_fraction_skipped, "ties");
  return names.empty() ? "" : "; over the limit: " + names;
}

}  // namespace

std::string describe_comparison(const Comparison& c, const ComparisonLimits& limits) {
  std::string classes;
  for (const auto& n : limits.classes) classes += (classes.empty() ? "" : "+") + n;
  return "pixels over " + std::to_string(limits.max_channel_difference) + "/255 " +
         format("%.3f%%", c.fraction_over * 100) + " of " + std::to_string(c.shaded) + " shaded (limit " +
         format("%.3f%%", limits.max_fraction_over * 100) + "), worst " + std::to_string(c.max_difference) +
         "/255 (limit " + std::to_string(limits.max_worst_difference) + "), relative RMSE " +
         format("%.2e", c.relative_rmse) + " (limit " + format("%.2e", limits.max_relative_rmse) + ")" +
         ", tie pixels skipped (shadow test, coverage) " + std::to_string(c.unstable) + " = " + format("%.3f%%", c.fraction_skipped * 100) +
         " (limit " + format("%.3f%%", limits.max_fraction_skipped * 100) + ")" +
         (c.non_finite ? ", " + std::to_string(c.non_finite) + " NaN/Inf values" : "") +
         (classes.empty() ? "" : " [" + classes + "]") + exceeded_measures(c, limits);
}

std::string write_failure_images(const std::filesystem::path& dir, const std::string& stem, const Image& rendered,
                                 const Image& reference, bool linear_output, const std::string& title,
                                 const std::string& details) {
  create_output_directory(dir);
  std::vector<uint8_t> a = encode_srgb8(rendered, linear_output), b = encode_srgb8(reference, linear_output);
  std::vector<uint8_t> diff(a.size());
  for (size_t i = 0; i < a.size(); ++i)
    diff[i] = i % 4 == 3 ? 255 : static_cast<uint8_t>(std::min(255, std::abs(int(a[i]) - int(b[i])) * 16));
  write_png(dir / (stem + ".render.png"), rendered.width, rendered.height, a);
  write_png(dir / (stem + ".reference.png"), rendered.width, rendered.height, b);
  write_png(dir / (stem + ".diff.png"), rendered.width, rendered.height, diff);
  auto img = [&](const char* kind) {
    return "<td><img src=\"" + stem + "." + kind + ".png\" width=\"256\" style=\"image-rendering:pixelated\"></td>";
  };
  return "<tr><td><b>" + title + "</b><br>" + details + "</td>" + img("render") + img("reference") + img("diff") + "</tr>";
}

void write_html_report(const std::filesystem::path& path, const std::string& title, const std::vector<std::string>& rows,
                       const std::string& rendered_by, const std::string& compared_with) {
  std::string html = "<!doctype html><meta charset=\"utf-8\"><title>" + title + "</title><h1>" + title +
                     "</h1><table border=\"1\" cellpadding=\"4\"><tr><th>variant</th><th>" + rendered_by + "</th>"
                     "<th>" + compared_with + "</th><th>|difference| x 16</th></tr>";
  for (const std::string& row : rows) html += row;
  html += "</table>\n";
  write_output(path, html);
}

}  // namespace kiln::render

#include <chrono>
#include <cstdio>
#include <ostream>
#include <unordered_map>
#include <unordered_set>

#include "kiln/pack_reader.hpp"
#include "kiln/manifest_json.hpp"
#include "render/backend.hpp"

namespace kiln::render {

std::vector<size_t> covering_sample(const std::vector<std::vector<uint32_t>>& rows, unsigned strength) {
  const size_t groups = rows.empty() ? 0 : rows.front().size();
  // Every value of every group gets a number; a combination is its values' numbers in group order, in one
  // integer of base `values` (at most 4 digits: fits 64 bits for up to 65,535 values).
  std::vector<uint64_t> first_value(groups + 1, 0);
  for (size_t g = 0; g < groups; ++g) {
    uint32_t count = 0;
    for (const auto& row : rows) {
      if (row.size() != groups) throw std::invalid_argument("covering_sample: rows of different lengths");
      count = std::max(count, row[g] + 1);
    }
    first_value[g + 1] = first_value[g] + count;
  }
  std::vector<size_t> chosen;
  if (strength == 0 || strength >= groups) {
    std::set<std::vector<uint32_t>> seen;
    for (size_t i = 0; i < rows.size(); ++i)
      if (seen.insert(rows[i]).second) chosen.push_back(i);
    return chosen;
  }
  if (strength > 4) throw std::invalid_argument("a covering sample's strength is at most 4");
  const uint64_t values = first_value[groups];
  if (values > 65535) throw std::invalid_argument("covering_sample: more than 65,535 keyword values");
  // A pack is input: its group count is bounded before the subsets of groups are listed (C(groups, strength) of them,
  // each looked up for every row).
  double subset_count = 1;
  for (unsigned k = 0; k < strength; ++k) subset_count = subset_count * double(groups - k) / double(k + 1);
  if (subset_count * double(rows.size()) > kMaxCoveringWork)
    throw std::invalid_argument("covering_sample: " + std::to_string(groups) + " keyword groups and " +
                                std::to_string(rows.size()) + " variants are too many for strength " +
                                std::to_string(strength) + " (" + std::to_string(uint64_t(subset_count)) +
                                " combinations of groups per variant)");
  // The combinations of `strength` groups, as index lists in lexicographic order.
  std::vector<std::vector<uint32_t>> subsets;
  std::vector<uint32_t> pick(strength);
  for (uint32_t i = 0; i < strength; ++i) pick[i] = i;
  for (;;) {
    subsets.push_back(pick);
    int k = int(strength) - 1;
    while (k >= 0 && pick[k] == groups - strength + k) --k;
    if (k < 0) break;
    ++pick[k];
    for (uint32_t j = k + 1; j < strength; ++j) pick[j] = pick[j - 1] + 1;
  }
  auto combinations = [&](const std::vector<uint32_t>& row, auto&& each) {
    for (const auto& subset : subsets) {
      uint64_t key = 0;
      for (uint32_t g : subset) key = key * values + first_value[g] + row[g];
      each(key);
    }
  };
  std::unordered_set<uint64_t> covered;
  auto gain = [&](size_t i) {
    size_t n = 0;
    combinations(rows[i], [&](uint64_t key) { n += !covered.count(key); });
    return n;
  };
  // Lazy greedy: a row's gain only falls as others are chosen, so a stale gain is an upper bound; the top of the
  // queue is chosen once its gain, recomputed, still beats every other bound.
  using Entry = std::pair<size_t, size_t>;  // (gain, row); the larger gain first, then the smaller row
  auto later = [](const Entry& a, const Entry& b) { return a.first != b.first ? a.first < b.first : a.second > b.second; };
  std::priority_queue<Entry, std::vector<Entry>, decltype(later)> queue(later);
  for (size_t i = 0; i < rows.size(); ++i) queue.push({subsets.size(), i});
  while (!queue.empty()) {
    auto [bound, row] = queue.top();
    queue.pop();
    const size_t now = gain(row);
    if (now == 0) continue;
    if (!queue.empty() && later({now, row}, queue.top())) {
      queue.push({now, row});
      continue;
    }
    chosen.push_back(row);
    combinations(rows[row], [&](uint64_t key) { covered.insert(key); });
  }
  std::sort(chosen.begin(), chosen.end());
  return chosen;
}

std::vector<size_t> covering_variants(const PackReader& pack, std::string_view pass, unsigned strength) {
  const std::vector<std::vector<std::string>> groups = pack.keyword_groups(pass);
  std::vector<std::vector<uint32_t>> rows;
  const size_t count = pack.variant_count(pass);
  for (size_t i = 0; i < count; ++i) {
    const SelectedVariant variant = pack.variant(pass, i);
    std::vector<uint32_t>& row = rows.emplace_back(groups.size(), 0);
    for (size_t g = 0; g < groups.size(); ++g) {
      // The group's keyword the variant has; else its off value ("_", an empty name), else its first.
      const auto& values = groups[g];
      auto on = std::find_if(values.begin(), values.end(), [&](const std::string& v) {
        return !v.empty() && std::find(variant.keywords.begin(), variant.keywords.end(), v) != variant.keywords.end();
      });
      if (on == values.end()) on = std::find(values.begin(), values.end(), std::string());
      row[g] = on == values.end() ? 0 : uint32_t(on - values.begin());
    }
  }
  try {
    return covering_sample(rows, strength);
  } catch (const std::invalid_argument& e) {  // too many groups or values for the strength: a hostile pack
    fail(DiagId::PackUnusable, {}, "pack '" + pack.name() + "': --cover " + std::to_string(strength) + ": " + e.what());
  }
}

std::vector<size_t> variants_to_run(const PackReader& pack, Api api, unsigned shard_index, unsigned shard_count,
                                    unsigned cover) {
  // A variant's pipeline is its pair of modules for the API; the pack stores each distinct output once.
  using Modules = std::pair<std::string_view, std::string_view>;
  struct ModulesHash {
    size_t operator()(const Modules& m) const {
      return std::hash<std::string_view>()(m.first) * 31 + std::hash<std::string_view>()(m.second);
    }
  };
  auto module = [&](const SelectedVariant& variant, const char* stage) {
    const StageView* view = variant.stage(stage);
    if (!view) return std::string_view();
    return api == Api::Vulkan ? view->spirv : api == Api::Gl ? view->glsl : view->gles;
  };
  std::unordered_map<Modules, size_t, ModulesHash> pipeline_of;  // -> pipeline number, in first-use order
  std::vector<std::vector<size_t>> by_pipeline;
  std::vector<size_t> candidates;
  if (cover) {
    candidates = covering_variants(pack, "Forward", cover);
  } else {
    candidates.resize(pack.variant_count("Forward"));
    std::iota(candidates.begin(), candidates.end(), size_t(0));
  }
  for (size_t i : candidates) {
    SelectedVariant variant = pack.variant("Forward", i);
    auto [it, inserted] = pipeline_of.try_emplace({module(variant, "vertex"), module(variant, "fragment")},
                                                  by_pipeline.size());
    if (inserted) by_pipeline.emplace_back();
    by_pipeline[it->second].push_back(i);
  }
  std::vector<size_t> run;
  for (size_t p = 0; p < by_pipeline.size(); ++p)
    if (p % shard_count == shard_index) run.insert(run.end(), by_pipeline[p].begin(), by_pipeline[p].end());
  return run;
}

namespace {

// Renders one variant; when that fails, prints `prefix` and the error as a NOT RUN line and counts it, with its exit
// status (a driver call that fails is kiln's bug, 2; a device that lacks a feature, 3; a variant the renderer cannot
// use, 1). Any other exception is a bug as well: reported the same way, and the run goes on to the next variant.
bool render_or_report(Backend& backend, const SelectedVariant& variant, const std::string& prefix, std::ostream& out,
                      GoldenTestSummary& summary, Image& image) {
  try {
    image = backend.render(variant);
    return true;
  } catch (const VerifyError& e) {
    const Diagnostic& d = e.diagnostic();
    out << prefix << "error[" << diagnostic_code(d.id) << "]: " << d.message << "\n";
    summary.worst_exit_status = worse_exit_status(summary.worst_exit_status, e.exit_status());
  } catch (const std::exception& e) {
    out << prefix << "internal error: " << e.what() << " (this is a bug in kiln)\n";
    summary.worst_exit_status = worse_exit_status(summary.worst_exit_status, exit_status(ExitClass::Internal));
  }
  ++summary.not_run;
  return false;
}

}  // namespace

GoldenTestSummary run_golden_test(const GoldenTestOptions& options, std::ostream& out) {
  auto start = std::chrono::steady_clock::now();
  GoldenTestSummary summary;
  PackReader pack = PackReader::open(options.pack_dir);
  Scene scene = load_scene(options.scene);
  std::vector<ToleranceClass> tolerances = load_tolerances(options.tolerances);
  const std::filesystem::path index_path = options.golden_dir / "index.json";
  std::ifstream index_file(index_path);
  if (!index_file) fail(DiagId::GoldenData, index_path, "no golden index (make one with kiln-reference goldens)");
  const nlohmann::json index = parse_json_file(index_file, index_path, DiagId::GoldenData);
  if (!index.is_object() || !index.contains("variants") || !index["variants"].is_object() ||
      !index.value("width", nlohmann::json(0u)).is_number_unsigned() ||
      !index.value("height", nlohmann::json(0u)).is_number_unsigned())
    fail(DiagId::GoldenData, index_path, "a golden index is an object with \"variants\" (an object) and unsigned \"width\" and \"height\"");
  const Api api = parse_api(options.api);
  if (!options.usage_log.empty()) pack.record_usage({options.usage_log, {{"scene", scene.name}, {"api", options.api}}});
  auto renderer = Backend::open(api, pack, scene, index.value("width", 0u), index.value("height", 0u));
  std::unique_ptr<CoverageRecorder> coverage;
  if (!options.coverage.empty()) {
    coverage = std::make_unique<CoverageRecorder>(pack, options.pack_dir);
    renderer->record_coverage(coverage.get());
  } else if (!options.coverage_json.empty()) {
    fail(DiagId::VerifyArgument, {}, "--coverage-json needs --coverage");
  }
  out << "kiln test: pack " << pack.name() << ", scene " << scene.name << ", " << renderer->width() << "x"
      << renderer->height() << ", " << renderer->device() << "\n";
  std::unique_ptr<Backend> other;
  if (!options.against.empty()) {
    other = Backend::open(parse_api(options.against), pack, scene, renderer->width(), renderer->height());
    out << "kiln test: compared with " << other->device() << " (not with the reference images)\n";
  }

  if (options.cover)
    out << "kiln test: a strength-" << options.cover << " covering sample: "
        << covering_variants(pack, "Forward", options.cover).size() << " of " << pack.variant_count("Forward")
        << " Forward variants\n";
  std::vector<std::string> rows;
  for (size_t i : variants_to_run(pack, api, options.shard_index, options.shard_count, options.cover)) {
    SelectedVariant variant = pack.variant("Forward", i);
    std::string name = variant_name(variant.keywords);
    if (!options.filter.empty() && name.find(options.filter) == std::string::npos) continue;
    if (!scene.judges(name)) continue;
    if (!options.usage_log.empty()) variant = pack.select("Forward", variant.keywords);  // what a game's lookup is
    const bool linear = std::find(variant.keywords.begin(), variant.keywords.end(), "_LINEAR_OUTPUT") != variant.keywords.end();
    auto golden = index["variants"].find(name);
    if (golden == index["variants"].end()) {
      out << "NOT RUN  #" << i << " " << name << ": no reference image in " << options.golden_dir.string() << "\n";
      ++summary.not_run;
      continue;
    }
    if (!golden->is_string()) fail(DiagId::GoldenData, index_path, "the image of '" + name + "' is not a file name");
    Image rendered;
    if (coverage) coverage->set_witness(scene.name + " #" + std::to_string(i) + " " + name);
    if (!render_or_report(*renderer, variant, "NOT RUN  #" + std::to_string(i) + " " + name + ": ", out, summary, rendered))
      continue;
    Image reference = read_kimg(options.golden_dir / golden->get<std::string>());
    if (other) {
      Image expected;
      if (!render_or_report(*other, variant, "NOT RUN  #" + std::to_string(i) + " " + name + ": " + options.against + ": ",
                            out, summary, expected))
        continue;
      // The reference still says which pixels are shaded and which are shadow-test ties.
      for (size_t p = 0; p + 3 < expected.rgba.size(); p += 4) expected.rgba[p + 3] = reference.rgba[p + 3];
      reference = std::move(expected);
    }
    ComparisonLimits limits = limits_for(tolerances, variant.keywords, scene.name);
    Comparison c = compare_images(rendered, reference, linear, limits);
    std::string details = describe_comparison(c, limits);
    out << (c.passed ? "PASS     #" : "FAIL     #") << i << " " << name << ": " << details << "\n";
    if (c.passed) {
      ++summary.passed;
    } else {
      ++summary.failed;
      if (!options.report_dir.empty())
        rows.push_back(write_failure_images(options.report_dir, "variant" + std::to_string(i), rendered, reference,
                                            linear, "#" + std::to_string(i) + " " + name, details));
    }
  }
  if (!rows.empty()) {
    write_html_report(options.report_dir / "index.html", "kiln test: " + pack.name() + " / " + scene.name + " (" + options.api + ")",
                      rows, api == Api::Vulkan ? "lavapipe" : "llvmpipe " + options.api,
                      options.against.empty() ? "CPU reference" : options.against);
    out << "kiln test: report with the failing images: " << (options.report_dir / "index.html").string() << "\n";
  }
  if (!options.usage_log.empty()) {
    const PackResult<size_t> sets = pack.flush_usage();
    if (!sets) fail(DiagId::OutputUnwritable, options.usage_log, std::string(sets.message()));
    out << "kiln test: usage log " << options.usage_log.string() << ": " << *sets << " keyword sets\n";
  }
  if (coverage) {
    coverage->write_lcov(options.coverage, scene.name);
    if (!options.coverage_json.empty()) coverage->write_json(options.coverage_json, scene.name);
    out << "kiln test: " << coverage->summary() << "; lcov tracefile " << options.coverage.string() << "\n";
  }
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  out << "kiln test: " << renderer->pipelines_created() << " " << (api == Api::Vulkan ? "pipelines" : "programs")
      << " compiled, " << renderer->pipelines_reused() << " renders reused one\n";
  out << "kiln test: " << summary.passed << " passed, " << summary.failed << " failed, " << summary.not_run
      << " not run, " << format("%.1f s", summary.seconds) << "\n";
  return summary;
}

}  // namespace kiln::render
