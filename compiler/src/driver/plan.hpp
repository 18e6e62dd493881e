// SPDX-License-Identifier: Apache-2.0
// Stages 0-3, shared by `kiln build`, `kiln list` and `kiln lint`: load the pack definition and scene profiles,
// scan each pass's declarations, expand the permutations and strip them.
#pragma once

#include <memory>
#include <vector>

#include "declarations/declarations.hpp"
#include "driver/build_context.hpp"
#include "definition/definition.hpp"
#include "kiln/build.hpp"
#include "permutations/permutations.hpp"
#include "permutations/usage.hpp"
#include "common/include_resolver.hpp"

namespace kiln {

struct Plan {
  PackDefinition pack;
  std::vector<SceneProfile> scenes;
  SourceSet sources;  // every file read, the build's one snapshot of each
  std::unique_ptr<IncludeRoots> roots;
  std::vector<PassDeclarations> declarations;  // per pass
  std::vector<PassKeywords> passes;            // per pass
  std::vector<PassExpansion> expansions;       // per pass: the variants kept
  std::vector<StripLine> strip;
  std::vector<UsageLog> usage;  // --usage: the logs with the tags asked for
  unsigned usage_margin = 0;    // --usage-margin
  // The command line's bindings and defines (applied to every pass already; the inputs hash covers them too).
  BindingOptions command_line_bindings;
  std::vector<Define> command_line_defines;
  std::map<std::string, KeywordKind> command_line_kinds;
  Funnel funnel;

  const std::string& entry_point(uint32_t pass, Stage stage) const {
    return pack.passes[pass].entry_points[static_cast<size_t>(stage)];
  }
  // A pass's keyword groups as the manifest records them: each group's stages narrowed to the pass's.
  std::vector<ManifestKeywordGroup> keyword_group_records(uint32_t pass) const;
};

// Nothing when an input is wrong (reported).
std::unique_ptr<Plan> make_plan(const BuildOptions& options, BuildContext& build);

}  // namespace kiln
