// SPDX-License-Identifier: Apache-2.0
// kiln fold-cost's library half (kiln/fold_cost.hpp): the plan with each group folded, and timed cold builds.
#include "kiln/fold_cost.hpp"

#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <set>

#include <nlohmann/json.hpp>

#include "common/files.hpp"
#include "common/keyword_pragmas.hpp"

namespace kiln {
namespace {

const SourceLocation kFoldOption{"<command line>", 0, 0};

std::vector<std::string> keywords_of(const KeywordGroup& group) {
  std::vector<std::string> out;
  for (const std::string& value : group.values)
    if (!value.empty()) out.push_back(value);
  return out;
}

double cpu_seconds(int who) {
  rusage usage{};
  getrusage(who, &usage);
  auto seconds = [](const timeval& t) { return double(t.tv_sec) + double(t.tv_usec) / 1e6; };
  return seconds(usage.ru_utime) + seconds(usage.ru_stime);
}

}  // namespace

BuildOptions folded_options(BuildOptions options, const std::vector<FoldCandidate>& candidates, KeywordKind kind) {
  for (const FoldCandidate& candidate : candidates)
    for (const std::string& keyword : candidate.keywords) options.keyword_kinds[keyword] = kind;
  return options;
}

std::optional<FoldPlan> plan_folds(const BuildOptions& options, const std::vector<std::vector<std::string>>& groups,
                                   DiagnosticSink& sink) {
  std::optional<PlanListing> listing = list_variants(options, sink);
  if (!listing) return std::nullopt;
  FoldPlan plan;
  plan.pack = listing->pack;
  plan.variants = listing->variants.size();
  plan.stage_sources = listing->stage_sources;
  // Each candidate once, by its keywords, with every pass that declares it.
  auto add = [&](const std::string& pass, const KeywordGroup& group) {
    std::vector<std::string> keywords = keywords_of(group);
    auto it = std::find_if(plan.candidates.begin(), plan.candidates.end(),
                           [&](const FoldCandidate& c) { return c.keywords == keywords; });
    if (it == plan.candidates.end()) {
      plan.candidates.push_back(FoldCandidate{keywords, {}, group.pragma});
      it = plan.candidates.end() - 1;
    }
    if (std::find(it->passes.begin(), it->passes.end(), pass) == it->passes.end()) it->passes.push_back(pass);
  };
  bool ok = true;
  if (groups.empty()) {
    for (const auto& [pass, pass_groups] : listing->pass_groups)
      for (const KeywordGroup& group : pass_groups)
        if (!is_folded(group.kind()) && !keywords_of(group).empty()) add(pass, group);
  } else {
    for (const std::vector<std::string>& named : groups) {
      const KeywordGroup* found = nullptr;
      std::vector<std::pair<std::string, const KeywordGroup*>> declaring;
      for (const auto& [pass, pass_groups] : listing->pass_groups)
        for (const KeywordGroup& group : pass_groups)
          if (!named.empty() && group.index_of(named.front()) >= 0) declaring.emplace_back(pass, found = &group);
      std::string problem;
      if (!found) problem = "no pass declares keyword '" + (named.empty() ? std::string() : named.front()) + "'";
      for (const std::string& keyword : named)
        if (found && found->index_of(keyword) < 0) problem = "'" + keyword + "' is not of the group of '" + named.front() + "'";
      if (!problem.empty()) {
        std::string text;
        for (const std::string& keyword : named) text += (text.empty() ? "" : ",") + keyword;
        sink.report(DiagId::InvalidCommandLineOption, kFoldOption, "--fold '" + text + "': " + problem);
        ok = false;
        continue;
      }
      for (const auto& [pass, group] : declaring) add(pass, *group);
    }
  }
  if (!ok) return std::nullopt;
  for (FoldCandidate& candidate : plan.candidates) {
    for (const auto& [path, text] : listing->sources)
      for (const std::string& keyword : candidate.keywords)
        if (text.find("KILN_FOLDED_" + keyword) != std::string::npos || text.find("KILN_GROUP_OF_" + keyword) != std::string::npos)
          candidate.written_for_folding = true;
    DiagnosticSink quiet;  // a group that cannot be folded is a finding, not the run's error
    auto folded = list_variants(folded_options(options, {candidate}, KeywordKind::SpecializationConstant), quiet);
    if (folded) {
      candidate.stage_sources = folded->stage_sources;
    } else if (const auto errors = quiet.diagnostics(); !errors.empty()) {
      candidate.cannot_fold = errors.front().message;
      // Folding a shader_feature group changes no variant count but the materials': they strip its values as
      // variants, and keep every value of it folded (its constant is set at run time). Say so: that is the cause.
      if (errors.front().id == DiagId::BudgetExceeded && is_material_feature_pragma(candidate.pragma))
        candidate.cannot_fold = "folded, a shader_feature group is no longer stripped by the pack's materials (every "
                                "material's variants keep each of its values), so " + candidate.cannot_fold +
                                "; fold it in a pack with a larger \"budget\", or keep it a variant";
    }
  }
  // "All folded" is every group that can be folded safely: one whose code does not test KILN_FOLDED_ would be wrong.
  std::vector<FoldCandidate> foldable;
  for (const FoldCandidate& candidate : plan.candidates)
    if (candidate.cannot_fold.empty() && candidate.written_for_folding) foldable.push_back(candidate);
  auto all = list_variants(folded_options(options, foldable, KeywordKind::SpecializationConstant), sink);
  if (!all) return std::nullopt;
  plan.all_folded = all->stage_sources;
  return plan;
}

std::optional<ColdBuild> cold_build(BuildOptions options, const std::filesystem::path& output_dir, DiagnosticSink& sink) {
  std::error_code ec;
  std::filesystem::remove_all(output_dir, ec);
  options.output_dir = output_dir;
  options.cache_dir.reset();
  options.remote = RemoteCacheOptions{};
  const double cpu_before = cpu_seconds(RUSAGE_SELF) + cpu_seconds(RUSAGE_CHILDREN);
  const auto start = std::chrono::steady_clock::now();
  const BuildReport report = build_pack(options, sink);
  ColdBuild out;
  out.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  out.cpu_s = cpu_seconds(RUSAGE_SELF) + cpu_seconds(RUSAGE_CHILDREN) - cpu_before;
  if (!report.ok) return std::nullopt;
  // The manifest kiln just wrote: its binaries and archive.
  auto text = read_binary_file(report.manifest);
  const nlohmann::json manifest = text ? nlohmann::json::parse(*text, nullptr, false) : nlohmann::json();
  if (!manifest.is_object() || !manifest.contains("binaries") || !manifest.contains("archive")) {
    sink.report(DiagId::FileUnreadable, SourceLocation{report.manifest.string(), 0, 0},
                "the manifest the build wrote cannot be read back");
    return std::nullopt;
  }
  out.modules = manifest["binaries"].size();
  out.pack_bytes = std::filesystem::file_size(output_dir / manifest["archive"].value("file", std::string()), ec);
  return out;
}

}  // namespace kiln
