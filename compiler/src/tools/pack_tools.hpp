// Tools over built packs: check a scene against a pack (every variant the scene can request must be
// there), and compare two packs (for review in CI).
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "kiln/diagnostics.hpp"
#include "kiln/pack_reader.hpp"

namespace kiln {

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

}  // namespace kiln
