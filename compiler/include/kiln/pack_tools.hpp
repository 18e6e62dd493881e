// SPDX-License-Identifier: Apache-2.0
// Tools over built packs (docs/usage.md): check a scene against a pack (every variant the scene can request must be
// there), compare two packs (for review in CI), check usage logs against a pack. Part of the compiler's public API
// (kiln::compiler), implemented in tools/: what kiln check-scene, diff-packs and check-usage do (merge-usage is
// kiln/recorded_usage.hpp's).
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <set>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "kiln/diagnostics.hpp"
#include "kiln/pack_reader.hpp"
#include "kiln/recorded_usage.hpp"
#include "kiln/result.hpp"

namespace kiln {

// ---- Built packs ----------------------------------------------------------------------------------------------

struct KeywordCombination {
  std::string pass;
  std::vector<std::string> keywords;  // sorted
};

struct SceneCheck {
  size_t requested = 0;                      // combinations the scene can request (valid, some material)
  std::vector<KeywordCombination> missing;   // of those, the ones the pack lacks
};

// Enumerates, per pass, every combination the scene can request under the pack's recorded constraints
// and material presets, and lists those without a variant in the pack.
std::optional<SceneCheck> check_scene(const PackReader& pack, const std::filesystem::path& scene_file, DiagnosticSink& sink);

struct PackDiff {
  std::vector<KeywordCombination> added;    // in B, not in A
  std::vector<KeywordCombination> removed;  // in A, not in B
  std::vector<KeywordCombination> changed;  // in both, with different binaries
};

PackDiff diff_packs(const PackReader& a, const PackReader& b);

// kiln check-usage (docs/usage.md): every keyword set the usage logs asked for (served or missing when they were
// recorded), selected in `pack` as the reader would. Each one the pack cannot serve is K1307 at its log, with the
// nearest variant the reader names; a log that dropped missing sets (over its recording's bound) is a warning.
struct UsageCheck {
  size_t sets = 0;            // keyword sets asked for, over all logs (a set in two logs counts twice)
  size_t missed = 0;          // of those, the ones the pack cannot serve
  uint64_t requests = 0;      // selections, counts summed
  uint64_t requests_missed = 0;
};
UsageCheck check_usage(const PackReader& pack, const std::vector<UsageLog>& logs, DiagnosticSink& sink);

}  // namespace kiln
