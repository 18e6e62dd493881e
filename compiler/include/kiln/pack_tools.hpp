// SPDX-License-Identifier: Apache-2.0
// Tools over built packs and the usage logs games record (docs/usage.md): check a scene against a pack (every variant
// the scene can request must be there), compare two packs (for review in CI), check and merge usage logs. Part of the
// compiler's public API (kiln::compiler): what kiln check-scene, diff-packs, check-usage and merge-usage do.
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
#include "kiln/result.hpp"

namespace kiln {

// ---- Usage logs -----------------------------------------------------------------------------------------------

struct UsageRequest {
  std::vector<std::string> keywords;  // sorted
  uint64_t count = 0;
  bool missing = false;               // the pack lacked it (the reader's Stripped)
  std::vector<std::string> nearest;   // when missing: the nearest variant the reader named
};

struct UsageLog {
  std::filesystem::path file;
  std::string text;  // as read (the inputs hash)
  std::string pack;
  std::map<std::string, std::string> tags;
  std::map<std::string, std::vector<UsageRequest>> passes;  // by pass name
  uint64_t missing_dropped = 0;
};

// Where the log names its pack (for a log of another pack); the file's start when the field cannot be found.
SourceLocation usage_log_pack_location(const UsageLog& log);

// Whether the log carries every tag of `filters` (key, value).
bool usage_matches(const UsageLog& log, const std::vector<std::pair<std::string, std::string>>& filters);

// The logs in `files` that carry every tag of `filters`, in order. A malformed one is reported (K1015) and left out;
// `without_tags`, when given, counts the well-formed ones left out for their tags.
std::vector<UsageLog> load_usage_logs(const std::vector<std::string>& files,
                                      const std::vector<std::pair<std::string, std::string>>& filters,
                                      DiagnosticSink& sink, size_t* without_tags = nullptr);

// `kiln merge-usage` (docs/usage.md, "Merging logs"): the logs as one log of the same format. Counts of the same
// keyword set are added (a served set and a missing set separately; a missing set keeps the first log's nearest
// variant); the tags are those every log has with the same value; with `passes` not empty, only those passes.
// Nothing (K1015 at the log) when the logs are of different packs.
struct UsageMerge {
  std::string text;  // the merged log
  size_t passes = 0, sets = 0;
  uint64_t selections = 0;
};
std::optional<UsageMerge> merge_usage_logs(const std::vector<UsageLog>& logs, const std::set<std::string>& passes,
                                           DiagnosticSink& sink);

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
// recorded), selected in `pack` as the reader would. Each one the pack cannot serve is K1016 at its log, with the
// nearest variant the reader names; a log that dropped missing sets (over its recording's bound) is a warning.
struct UsageCheck {
  size_t sets = 0;            // keyword sets asked for, over all logs (a set in two logs counts twice)
  size_t missed = 0;          // of those, the ones the pack cannot serve
  uint64_t requests = 0;      // selections, counts summed
  uint64_t requests_missed = 0;
};
UsageCheck check_usage(const PackReader& pack, const std::vector<UsageLog>& logs, DiagnosticSink& sink);

}  // namespace kiln
