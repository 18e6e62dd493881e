// SPDX-License-Identifier: Apache-2.0
// kiln fold-cost: what folding each keyword group would save and cost (docs/keywords.md "Choosing a kind"). The
// plan with each group folded (kiln/fold_cost.hpp), cold builds timed side by side (--reps), and the same variants
// drawn on lavapipe from the pack built as variants, dynamic branches and specialization constants
// (--render-scene: kiln-verify draw-cost), with a recommendation per keyword.
#include <spawn.h>
#include <sys/wait.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

#include "cli.hpp"
#include "kiln/files.hpp"
#include "kiln/fold_cost.hpp"

extern char** environ;

namespace kiln::cli {
namespace {

using nlohmann::json;

constexpr double kThreshold = 0.02;        // a run-time cost above it (and above the noise) keeps a keyword a variant
constexpr double kImageDifference = 1e-2;  // a folded image further from the variant's: the shader is not written for it
const KeywordKind kDrawnKinds[] = {KeywordKind::DynamicBranch, KeywordKind::SpecializationConstant,
                                   KeywordKind::SpecializationInteger};

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v.size() % 2 ? v[v.size() / 2] : (v[v.size() / 2 - 1] + v[v.size() / 2]) / 2;
}

std::string joined(const std::vector<std::string>& words, const char* separator = " ") {
  std::string out;
  for (const std::string& w : words) out += (out.empty() ? "" : separator) + w;
  return out;
}

std::string fixed(double value, int digits) {
  char text[32];
  std::snprintf(text, sizeof text, "%.*f", digits, value);
  return text;
}

std::vector<std::string> sorted(std::vector<std::string> words) {
  std::sort(words.begin(), words.end());
  return words;
}

std::string percent(double ratio) { return (ratio >= 0 ? "+" : "") + fixed(100 * ratio, 1) + "%"; }

int run_program(const std::filesystem::path& program, const std::vector<std::string>& arguments) {
  std::vector<std::string> argv_text{program.string()};
  argv_text.insert(argv_text.end(), arguments.begin(), arguments.end());
  std::vector<char*> argv;
  for (std::string& a : argv_text) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  if (posix_spawn(&pid, argv[0], nullptr, nullptr, argv.data(), environ) != 0) return -1;
  int status = 0;
  while (waitpid(pid, &status, 0) < 0)
    if (errno != EINTR) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

class FoldCostVerb final : public Verb {
 public:
  CLI::App* add_to(CLI::App& app) override {
    CLI::App* verb = app.add_subcommand(
        "fold-cost", "What folding each keyword group (" + keyword_kind_list({}, true) + ") would save and cost");
    verb->add_option("pack", pack_file_, "Pack definition")->required();
    plan_.add_to(verb);
    verb->add_option("--fold", fold_texts_,
                     "KEYWORD[,KEYWORD...]: a group to consider (one keyword names its group; repeatable; default: every "
                     "group built as variants)");
    verb->add_option("--reps", reps_, "Cold builds of the pack as it is, each group folded alone and all folded, this many "
                                      "rounds interleaved (default 0: the plan only)");
    verb->add_option("-j,--jobs", jobs_, "Compiler worker processes for the builds (default, or 0: one per core)");
    verb->add_option("--render-scene", render_scene_,
                     "Draw the same variants of this render scene (variants/scenes/render/*.json) from the pack built as "
                     "variants, dynamic branches and specialization constants on lavapipe (runs kiln-verify)")
        ->check(CLI::ExistingFile);
    verb->add_option("--frames", frames_, "With --render-scene: draws per pack, row and round (default 15)");
    verb->add_option("--rounds", rounds_, "With --render-scene: interleaved rounds (default 5)");
    verb->add_option("--base", base_, "With --render-scene: keywords every drawn variant holds, space-separated "
                                      "(what a folded keyword needs to matter: a shadow map for soft shadows)");
    verb->add_option("--json", json_file_, "Also write the results as JSON ('-': standard output, the table to standard error)");
    return verb;
  }

  int run() override {
    BuildOptions options;
    options.pack_file = pack_file_;
    options.jobs = jobs_;
    if (!plan_.apply(options)) return 1;
    std::vector<std::vector<std::string>> groups;
    for (const std::string& text : fold_texts_) {
      std::vector<std::string>& group = groups.emplace_back();
      std::stringstream in(text);
      for (std::string keyword; std::getline(in, keyword, ',');) group.push_back(keyword);
    }
    std::ostream& out = json_file_ == "-" ? std::cerr : std::cout;
    DiagnosticSink sink;
    print_diagnostics_as_they_come(sink);
    std::optional<FoldPlan> plan = plan_folds(options, groups, sink);
    if (!plan) return exit_code(sink, false);
    json result = report_plan(*plan, out);
    // Measured: the groups that can be folded safely.
    std::erase_if(plan->candidates, [](const FoldCandidate& c) { return !c.cannot_fold.empty() || !c.written_for_folding; });
    const std::filesystem::path scratch = make_scratch("kiln-fold-cost-");
    if ((reps_ > 0 || !render_scene_.empty()) && scratch.empty()) {
      std::cerr << "kiln: error[K1601]: no scratch directory for the builds (TMPDIR, /tmp, /var/tmp)\n";
      return exit_status(ExitClass::Environment);
    }
    int code = 0;
    if (reps_ > 0 && !measure_builds(options, *plan, scratch, result, out, sink)) code = exit_code(sink, false);
    if (code == 0 && !render_scene_.empty()) code = measure_draws(options, *plan, scratch, result, out, sink);
    std::error_code ec;
    if (!scratch.empty()) std::filesystem::remove_all(scratch, ec);
    if (code == 0) recommend(*plan, result, out);
    if (json_file_ == "-") {
      std::cout << result.dump(2) << "\n";
    } else if (!json_file_.empty()) {
      if (Result<void> written = write_output_file(json_file_, result.dump(2) + "\n"); !written) {
        std::cerr << "kiln: error[K1601]: --json: " << written.error().message << "\n";
        return exit_status(ExitClass::Environment);
      }
    }
    return code;
  }

 private:
  static json report_plan(const FoldPlan& plan, std::ostream& out) {
    out << "kiln fold-cost: pack '" << plan.pack << "': " << plan.variants << " variants, " << plan.stage_sources
        << " stage sources (planned: nothing preprocessed or compiled)\n";
    json candidates = json::array();
    auto saved = [&](size_t sources) {
      const double ratio = plan.stage_sources ? double(sources) / double(plan.stage_sources) - 1 : 0;
      return std::to_string(sources) + " (" + percent(ratio) + ")";
    };
    size_t foldable = 0, unsafe = 0;
    for (const FoldCandidate& c : plan.candidates) {
      out << "  " << joined(c.keywords) << " [" << joined(c.passes, ", ") << "]: ";
      if (!c.cannot_fold.empty()) {
        out << "cannot be folded: " << c.cannot_fold << "\n";
      } else if (!c.written_for_folding) {
        ++unsafe;
        out << "unsafe to fold: no source tests KILN_FOLDED_" << c.keywords.front()
            << " (or KILN_GROUP_OF_), so folded, its #if defined() would hold for every value; folded alone it would be "
            << saved(c.stage_sources) << " stage sources\n";
      } else {
        ++foldable;
        out << "folded alone, " << saved(c.stage_sources) << " stage sources\n";
      }
      candidates.push_back({{"keywords", c.keywords}, {"passes", c.passes}, {"pragma", c.pragma},
                            {"written_for_folding", c.written_for_folding}, {"stage_sources", c.stage_sources},
                            {"cannot_fold", c.cannot_fold}, {"safe", c.cannot_fold.empty() && c.written_for_folding}});
    }
    out << "  all " << foldable << " that can be folded safely, folded: " << saved(plan.all_folded) << " stage sources"
        << (unsafe ? " (" + std::to_string(unsafe) + " unsafe to fold left out)" : "") << "\n";
    return {{"pack", plan.pack}, {"variants", plan.variants}, {"stage_sources", plan.stage_sources},
            {"candidates", candidates}, {"all_folded_stage_sources", plan.all_folded}};
  }

  bool measure_builds(const BuildOptions& options, const FoldPlan& plan, const std::filesystem::path& scratch,
                      json& result, std::ostream& out, DiagnosticSink& sink) const {
    struct Config {
      std::string name;
      BuildOptions options;
      std::vector<ColdBuild> runs;
    };
    std::vector<Config> configs{{"as it is", options, {}}};
    for (const FoldCandidate& c : plan.candidates)
      configs.push_back({joined(c.keywords) + " folded", folded_options(options, {c}, KeywordKind::SpecializationConstant), {}});
    configs.push_back({"all folded", folded_options(options, plan.candidates, KeywordKind::SpecializationConstant), {}});
    for (unsigned rep = 0; rep < reps_; ++rep)
      for (size_t i = 0; i < configs.size(); ++i) {
        std::optional<ColdBuild> build = cold_build(configs[i].options, scratch / ("build-" + std::to_string(i)), sink);
        if (!build) return false;
        configs[i].runs.push_back(*build);
        std::cerr << "kiln fold-cost: round " << rep + 1 << "/" << reps_ << ": " << configs[i].name << " "
                  << fixed(build->wall_s, 2) << " s\n";
      }
    auto wall = [](const Config& c) {
      std::vector<double> v;
      for (const ColdBuild& b : c.runs) v.push_back(b.wall_s);
      return median(v);
    };
    out << "cold builds (no cache, " << reps_ << " rounds interleaved, medians):\n";
    json builds = json::array();
    for (const Config& c : configs) {
      std::vector<double> walls, cpus;
      for (const ColdBuild& b : c.runs) walls.push_back(b.wall_s), cpus.push_back(b.cpu_s);
      const double ratio = wall(configs.front()) / wall(c);
      out << "  " << c.name << ": " << fixed(wall(c), 2) << " s (" << fixed(ratio, 2) << "x), " << c.runs.front().modules
          << " modules, " << fixed(double(c.runs.front().pack_bytes) / 1e6, 2) << " MB\n";
      builds.push_back({{"config", c.name}, {"wall_s", median(walls)}, {"cpu_s", median(cpus)}, {"walls", walls},
                        {"speedup", ratio}, {"modules", c.runs.front().modules}, {"pack_bytes", c.runs.front().pack_bytes}});
    }
    result["builds"] = builds;
    result["reps"] = reps_;
    return true;
  }

  int measure_draws(const BuildOptions& options, const FoldPlan& plan, const std::filesystem::path& scratch, json& result,
                    std::ostream& out, DiagnosticSink& sink) const {
    const std::optional<std::filesystem::path> verify = find_verify();
    if (!verify) {
      std::cerr << "kiln: error: " << no_verify_message("fold-cost --render-scene") << "\n";
      return 1;
    }
    // Only the groups whose code is written for folding: folded, another's #if would hold for every value, and its
    // image would say so for every row.
    std::vector<FoldCandidate> drawn;
    for (const FoldCandidate& c : plan.candidates) {
      if (c.written_for_folding) drawn.push_back(c);
      else std::cerr << "kiln fold-cost: " << joined(c.keywords) << " is not drawn folded: no source tests KILN_FOLDED_ of it\n";
    }
    if (drawn.empty()) {
      out << "run-time cost: nothing to draw (no group's code is written for folding: docs/keywords.md)\n";
      return 0;
    }
    // The packs, built with one cache (their unfolded stages are the same modules).
    json packs = json::array();
    std::vector<std::pair<std::string, BuildOptions>> kinds{{"variant", options}};
    for (KeywordKind kind : kDrawnKinds) kinds.emplace_back(std::string(keyword_kind_name(kind)), folded_options(options, drawn, kind));
    for (auto& [kind, pack_options] : kinds) {
      pack_options.output_dir = scratch / ("draw-" + kind);
      pack_options.cache_dir = scratch / "cache";
      std::cerr << "kiln fold-cost: building the pack as " << kind << "\n";
      if (!build_pack(pack_options, sink).ok) return exit_code(sink, false);
      packs.push_back({{"kind", kind}, {"dir", pack_options.output_dir.string()}});
    }
    // The variant pack twice: the second renderer's difference from the first is the measurement's own noise (A/A).
    packs.push_back({{"kind", "variant again"}, {"dir", (scratch / "draw-variant").string()}});
    std::vector<std::string> base;
    std::istringstream words(base_);
    for (std::string w; words >> w;) base.push_back(w);
    // A row per keyword: the Forward variant of the base keywords and it, where the pack has that variant.
    std::optional<PlanListing> listing = list_variants(options, sink);
    if (!listing) return exit_code(sink, false);
    std::set<std::vector<std::string>> forward;
    for (const VariantListing& v : listing->variants)
      if (v.pass == "Forward") forward.insert(sorted(v.keywords));
    json rows = json::array();
    auto add_row = [&](const std::string& name, std::vector<std::string> keywords) {
      if (forward.contains(sorted(keywords))) rows.push_back({{"name", name}, {"keywords", keywords}});
      else std::cerr << "kiln fold-cost: the pack has no Forward variant [" << joined(keywords) << "]: " << name << " is not drawn\n";
    };
    add_row("all folded keywords off", base);
    for (const FoldCandidate& c : drawn)
      for (const std::string& keyword : c.keywords) {
        std::vector<std::string> keywords = base;
        if (std::find(base.begin(), base.end(), keyword) == base.end()) keywords.push_back(keyword);
        add_row(keyword + " on", keywords);
      }
    if (rows.empty()) {
      std::cerr << "kiln: error: no variant to draw: the pack has no Forward variant of the --base keywords\n";
      return 1;
    }
    const json config = {{"scene", render_scene_}, {"frames", frames_}, {"rounds", rounds_}, {"packs", packs}, {"rows", rows}};
    const std::filesystem::path config_file = scratch / "draw-cost.json", out_file = scratch / "draw-cost-out.json";
    std::ofstream(config_file) << config.dump(1);
    if (const int status = run_program(*verify, {"draw-cost", config_file.string(), out_file.string()}); status != 0) {
      std::cerr << "kiln: error: kiln-verify draw-cost failed (exit " << status << ")\n";
      return status > 0 ? status : 2;
    }
    std::ifstream in(out_file);
    json frames = json::parse(in, nullptr, false);
    if (frames.is_discarded() || !frames.contains("rows")) {
      std::cerr << "kiln: error: kiln-verify draw-cost wrote no result\n";
      return 2;
    }
    // Each kind against the variant pack's two renderers pooled; a cost counts above 2% and above the A/A noise.
    auto pooled = [](const json& row) {
      return (row["draw_ms_median"]["variant"].get<double>() + row["draw_ms_median"]["variant again"].get<double>()) / 2;
    };
    double noise = 0;
    for (const json& row : frames["rows"])
      noise = std::max(noise, std::abs(row["draw_ms_median"]["variant"].get<double>() -
                                       row["draw_ms_median"]["variant again"].get<double>()) / pooled(row));
    frames["noise"] = noise;
    const double bar = std::max(kThreshold, noise);
    out << "run-time cost on lavapipe (" << frames.value("device", std::string()) << "; scene " << frames.value("scene", std::string())
        << ", " << frames_ << " frames x " << rounds_ << " rounds interleaved, medians; the variant pack against itself: "
        << percent(noise) << "):\n";
    for (json& row : frames["rows"]) {
      std::string line = "  " + row["name"].get<std::string>() + ": variant " + fixed(pooled(row), 2) + " ms";
      std::string recommendation = "variant (folding costs more than " + percent(bar) + ")";
      for (KeywordKind kind : kDrawnKinds) {
        const std::string name(keyword_kind_name(kind));
        const double cost = row["draw_ms_median"][name].get<double>() / pooled(row) - 1;
        const double difference = row["largest_relative_difference"][name].get<double>();
        row["cost"][name] = cost;
        line += ", " + name + " " + percent(cost) + (difference > kImageDifference ? " (image differs)" : "");
        if (recommendation.starts_with("variant") && cost <= bar && difference <= kImageDifference)
          recommendation = name + " (" + percent(cost) + ")";
        if (difference > kImageDifference && recommendation.starts_with("variant"))
          recommendation = "variant (folded, its image differs by " + fixed(100 * difference, 1) +
                           "%: its code is not written for folding)";
      }
      if (noise > kThreshold)
        recommendation = "none: the measurement's own noise is " + percent(noise) + ", above the " + percent(kThreshold) +
                         " a recommendation needs";
      row["recommendation"] = recommendation;
      out << line << " -> " << recommendation << "\n";
    }
    if (noise > kThreshold)
      out << "  the variant pack drawn against itself differed by " << percent(noise) << ", more than the " << percent(kThreshold)
          << " a cost must exceed to count: nothing is recommended from these draws; run again on a quieter machine, "
             "or with more --frames and --rounds\n";
    result["frames"] = frames;
    return 0;
  }

  // The "keyword_kinds" block to paste into the pack: each group that can be folded safely, with the kind its draws
  // recommend (--render-scene), or without draws the kind that usually costs nothing (a bool constant; an int for a
  // group of several keywords), said to be unmeasured. A group the draws keep a variant, or whose draws were too
  // noisy to decide, is left out.
  void recommend(const FoldPlan& plan, json& result, std::ostream& out) const {
    const json* rows = result.contains("frames") ? &result["frames"]["rows"] : nullptr;
    const bool noisy = rows && result["frames"].value("noise", 0.0) > kThreshold;
    json kinds = json::object();
    std::vector<std::string> why;
    for (const FoldCandidate& c : plan.candidates) {
      std::string kind = c.keywords.size() > 1 ? "specialization_constant_int" : "specialization_constant";
      if (rows) {
        // The first kind that every row of the group (and the row with all folded keywords off) accepts: within the
        // bar and the image tolerance, as each row's own recommendation is made.
        const double bar = std::max(kThreshold, result["frames"].value("noise", 0.0));
        kind.clear();
        for (KeywordKind candidate : kDrawnKinds) {
          const std::string name(keyword_kind_name(candidate));
          bool accepted = !noisy;
          for (const json& row : *rows) {
            const std::string row_name = row["name"].get<std::string>();
            const bool ours = row_name == "all folded keywords off" ||
                              std::any_of(c.keywords.begin(), c.keywords.end(), [&](const std::string& k) { return row_name == k + " on"; });
            if (ours && (row["cost"][name].get<double>() > bar || row["largest_relative_difference"][name].get<double>() > kImageDifference))
              accepted = false;
          }
          if (accepted) {
            kind = name;
            break;
          }
        }
        if (kind.empty()) {
          why.push_back(joined(c.keywords) + ": " + (noisy ? "not decided (the draws were too noisy)" : "kept a variant (every kind cost more)"));
          continue;
        }
      }
      for (const std::string& keyword : c.keywords) kinds[keyword] = kind;
    }
    result["recommended_keyword_kinds"] = kinds;
    out << "recommended \"keyword_kinds\" (paste into the pack definition" << (rows ? "" : "; not measured at run time: "
        "--render-scene draws each kind") << "):\n";
    std::string block = "  \"keyword_kinds\": " + (kinds.empty() ? std::string("{}") : kinds.dump(2)) + (kinds.empty() ? "\n" : ",\n");
    for (size_t at = 0; (at = block.find('\n', at)) != std::string::npos && at + 1 < block.size(); at += 3) block.insert(at + 1, "  ");
    out << block;
    for (const std::string& line : why) out << "  left out: " << line << "\n";
  }

  std::string pack_file_;
  PlanArguments plan_;
  std::vector<std::string> fold_texts_;
  unsigned reps_ = 0, jobs_ = 0, frames_ = 15, rounds_ = 5;
  std::string render_scene_, base_, json_file_;
};

}  // namespace

std::unique_ptr<Verb> make_fold_cost_verb() { return std::make_unique<FoldCostVerb>(); }

}  // namespace kiln::cli
