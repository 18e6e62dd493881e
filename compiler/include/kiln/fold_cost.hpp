// SPDX-License-Identifier: Apache-2.0
// What folding a keyword group would save (`kiln fold-cost`, docs/keywords.md "Choosing a kind"): for each group,
// the stage sources the pack would have with that group folded into one module, from the plan alone (nothing is
// preprocessed or compiled); and cold builds of the pack as it is and folded, timed side by side. The run-time half
// (drawing the same variants from each folded pack on lavapipe) is kiln-verify's: the compiler links no renderer.
// Part of the compiler's public API.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "kiln/build.hpp"
#include "kiln/folded_keywords.hpp"

namespace kiln {

struct FoldCandidate {
  std::vector<std::string> keywords;  // the group's keywords, its off value aside, as declared
  std::vector<std::string> passes;    // the passes that declare it
  std::string pragma;                 // as the first of them builds it
  bool written_for_folding = false;   // some source tests KILN_FOLDED_<K> or KILN_GROUP_OF_<K> of one of them
  size_t stage_sources = 0;           // the pack's distinct stage sources with this group folded alone
  std::string cannot_fold;            // why the pack does not plan with this group folded (its first error), or ""
};

struct FoldPlan {
  std::string pack;
  size_t variants = 0;
  size_t stage_sources = 0;  // as the pack is
  std::vector<FoldCandidate> candidates;
  size_t all_folded = 0;     // with every candidate folded that can be folded safely (written for folding)
};

// `groups`: each names keywords of one group (one keyword is enough: a group folds whole). Empty: every group that
// is built as variants and has a keyword. A keyword no pass declares, or two groups in one entry, is K1014.
std::optional<FoldPlan> plan_folds(const BuildOptions& options, const std::vector<std::vector<std::string>>& groups,
                                   DiagnosticSink& sink);

// `options` with every keyword of `candidates` built as `kind` (BuildOptions::keyword_kinds).
BuildOptions folded_options(BuildOptions options, const std::vector<FoldCandidate>& candidates, KeywordKind kind);

// One cold build (no cache, no remote) into `output_dir`: its time and what it wrote.
struct ColdBuild {
  double wall_s = 0, cpu_s = 0;  // cpu: this process and its workers
  size_t modules = 0;            // distinct binaries in the manifest
  uint64_t pack_bytes = 0;       // the archive's size
};
std::optional<ColdBuild> cold_build(BuildOptions options, const std::filesystem::path& output_dir, DiagnosticSink& sink);

}  // namespace kiln
