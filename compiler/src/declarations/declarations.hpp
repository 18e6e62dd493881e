// SPDX-License-Identifier: Apache-2.0
// Stage 1: read a pass's entry file and every file it includes (whatever the #if around the
// #include), and collect the keyword declarations (#pragma multi_compile / shader_feature ...).
#pragma once

#include <array>

#include <map>
#include <optional>
#include <set>

#include "common/files.hpp"
#include "kiln/model.hpp"
#include "kiln/result.hpp"
#include "common/include_resolver.hpp"

namespace kiln {

struct SourceFile {
  std::filesystem::path path;  // canonical
  std::string text;            // BOM removed
  bool guarded = false;        // #pragma once or a classic #ifndef/#define guard
  bool pragma_once = false;    // the includer must serve it only once per preprocess
  // Every #include the scan resolved in this file (any branch of any #if): the name as written -> the
  // file (canonical). Preprocessing serves includes from this table, never from the file system.
  std::map<std::string, std::filesystem::path> includes;
};

// Every file read by any pass of a build, by canonical path. Preprocessing serves includes from here,
// so one build sees one consistent snapshot of each file.
struct SourceSet {
  std::map<std::filesystem::path, SourceFile> files;
  // Directories where a new file would shadow an include (ResolvedInclude::watch): the depfile lists them.
  std::set<std::filesystem::path> watched;
  // Unity pragmas kiln reads but does not act on, already noted (file and line): a header of many passes says it once.
  std::set<std::pair<std::filesystem::path, int>> noted;
  const SourceFile* find(const std::filesystem::path& canonical) const;
};

struct PassDeclarations {
  std::filesystem::path entry;                 // canonical
  std::vector<std::filesystem::path> files;    // entry first, then includes in discovery order
  std::vector<KeywordGroup> groups;            // in declaration order
  // Each stage's own entry file (canonical), for a pass whose stages have files of their own; `entry` otherwise.
  std::array<std::filesystem::path, kStageCount> stage_entry;
  // Unity's stage pragmas (`#pragma vertex vert`, `fragment`, `geometry`, `hull`, `domain`, `kernel` for compute):
  // the entry point each names, the first of each stage, and where. A pass without "stages" takes its stages from them.
  struct StagePragma {
    std::string entry;
    SourceLocation at;
  };
  std::array<std::optional<StagePragma>, kStageCount> stage_pragmas;
};

// One pass's declarations from the files its stages name: a keyword declared in a stage's file applies to the
// stages whose files declare it (narrowed further by its pragma's stage suffix); a group declared alike in two
// files is one group.
std::optional<PassDeclarations> scan_pass_declarations(const PassDefinition& pass, const IncludeRoots& roots,
                                                       const ReadLimits& limits, SourceSet& sources, DiagnosticSink& sink);

// A pass written the Unity way names its entry points with `#pragma vertex` / `#pragma fragment` in its source and
// none in the pack: gives it those stages (K1311 when its source names none). When the pack names stages too, each
// pragma that names another entry point is a warning (K1311), and the pack's entry point is used.
bool apply_stage_pragmas(PassDefinition& pass, const IncludeRoots& roots, const ReadLimits& limits, SourceSet& sources,
                         DiagnosticSink& sink);

inline constexpr int kMaxIncludeDepth = 64;

std::optional<PassDeclarations> scan_declarations(const std::filesystem::path& entry, const IncludeRoots& roots,
                                                  const ReadLimits& limits, SourceSet& sources, DiagnosticSink& sink);

// Parses one `#pragma` line body (text after "pragma"): its keyword group, nothing when it is some other pragma, or
// the error of a malformed keyword pragma (for the caller to report, or not: lint leaves it to kiln build).
Result<std::optional<KeywordGroup>, Diagnostic> parse_keyword_pragma(std::string_view body, const SourceLocation& at,
                                                                    int body_column);

// is_identifier (a keyword must be a preprocessor identifier) is in kiln/model.hpp: defines use it too.

// Source lines with comments blanked out (same length, so columns stay true); shared with lint.
std::vector<std::string> code_lines(std::string_view text);

}  // namespace kiln
