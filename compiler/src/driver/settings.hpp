// SPDX-License-Identifier: Apache-2.0
// What every output of a build depends on besides its sources: the tools (front end, SPIRV-Tools, SPIRV-Cross,
// kiln's compile job revision), the options and the targets. Every cache key starts with it, and so does the
// inputs hash that makes a no-change build a no-op.
#pragma once

#include <algorithm>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "common/hash.hpp"
#include "driver/plan.hpp"
#include "frontend/frontend.hpp"
#include "kiln/build.hpp"
#include "kiln/pack_format.hpp"

namespace kiln {

struct BuildSettings {
  std::unique_ptr<Frontend> frontend;
  std::string fingerprint;      // tools and their versions
  std::vector<Target> targets;  // sorted; SPIR-V always included
  std::string target_names;     // "spirv,glsl,..." as hashed
  bool targets_from_command_line = false;

  // What a pass is built for: its own "targets" if it has them (narrowed by --targets when given), else the
  // build's. A pass without its own list hashes exactly what it always did.
  std::vector<Target> targets_for(const PassDefinition& pass) const {
    if (pass.targets.empty()) return targets;
    if (!targets_from_command_line) return pass.targets;
    std::vector<Target> both;
    for (Target t : pass.targets)
      if (std::find(targets.begin(), targets.end(), t) != targets.end()) both.push_back(t);
    return both;
  }
  std::string target_names_for(const PassDefinition& pass) const {
    if (pass.targets.empty()) return target_names;
    std::string names;
    for (Target t : targets_for(pass)) names += std::string(target_name(t)) + ",";
    return names;
  }
  bool optimize = true;
  bool debug_info = false;  // hashed only when on: the keys of every build without it are unchanged
  bool coverage = false;    // likewise
  OptimizerRecipe optimizer_recipe = OptimizerRecipe::Kiln;

  // The start of every compile's cache key: what its output depends on besides its input (the pass gives the
  // entry point and the binding options). A Hasher for local keys, a RemoteKeyHasher for remote ones: the same
  // fields. "binding model 1" marks keys made since kiln's own resolver assigns glslang's bindings (a resource
  // without a register was at binding 0 before): cache entries of older builds are not reused. It is not a
  // kCompileJobRevision bump because that revision is in the inputs hash, which the manifest records: packs
  // whose bindings did not change keep their bytes. "hlsl compat 1" likewise marks keys made since the front end
  // rewrites DXC's spellings (frontend/hlsl_compat.hpp), gives files a final newline and checks thread groups and
  // block sizes: a cached push-constant struct of an older build was a $Global uniform buffer. "hlsl compat 2":
  // unbounded resource arrays are runtime arrays, SV_ViewID and SV_ShadingRate built-ins (frontend/dxc_semantics.hpp),
  // and NonUniformResourceIndex is DXC's (frontend/nonuniform.hpp): an older build's module had other interfaces.
  // "hlsl compat 3": attribute lists and a [[vk::push_constant]] on its own line are read as DXC reads them, stated
  // locations stay beside SV_ViewID, and reflections give texel buffers and input attachments their own kinds (and
  // MSL records storage images): an older build's cached output had other interfaces or reflections.
  template <typename KeyHasher>
  KeyHasher& add_compile_options(KeyHasher& hasher, const PassDefinition& pass, Stage stage) const {
    hasher.add(fingerprint).add(optimize ? 1 : 0).add(optimizer_recipe_name(optimizer_recipe)).add(target_names_for(pass)).add(stage_name(stage))
        .add(pass.entry_points[static_cast<size_t>(stage)]).add("binding model 1").add("hlsl compat 3")
        .add(pass.bindings_for(stage).canonical());
    if (debug_info) hasher.add("debug info");
    if (coverage) hasher.add("coverage 1");
    return hasher;
  }
};

// What the inputs hash covers: the tools, options, pack format (a pack another format version wrote is rebuilt),
// the command line's bindings and defines, and every file read (its path from the pack's directory and its bytes). Also the remote's pack-level key.
template <typename KeyHasher>
void add_build_inputs(KeyHasher& hasher, const BuildSettings& settings, const Plan& plan) {
  hasher.add(uint64_t{kPackFormatVersion});
  hasher.add(settings.fingerprint).add(settings.optimize ? 1 : 0).add(optimizer_recipe_name(settings.optimizer_recipe))
      .add(settings.target_names).add(plan.pack.text);
  if (settings.debug_info) hasher.add("debug info");
  if (settings.coverage) hasher.add("coverage 1");
  for (const SceneProfile& scene : plan.scenes) hasher.add(scene.text);
  for (const UsageLog& log : plan.usage) hasher.add("usage log").add(log.text);
  if (!plan.usage.empty()) hasher.add("usage margin").add(uint64_t{plan.usage_margin});
  // The pack's own bindings and defines are in its text; the command line's are added when given (a build
  // without them keeps the inputs hash, and so the manifest, it always had).
  if (!plan.command_line_bindings.canonical().empty()) hasher.add("bindings").add(plan.command_line_bindings.canonical());
  for (const Define& define : plan.command_line_defines) hasher.add("define").add(define.name).add(define.value);
  for (const auto& [keyword, kind] : plan.command_line_kinds) hasher.add("keyword kind").add(keyword).add(keyword_kind_name(kind));
  // Each file by its path from the pack's directory, in that order: the same sources checked out elsewhere (another
  // CI runner's work tree, a developer's home) have the same inputs, so the same manifest and pack-level key.
  const std::filesystem::path base = std::filesystem::weakly_canonical(plan.pack.file).parent_path();
  std::vector<std::pair<std::string, const std::string*>> files;
  for (const auto& [path, file] : plan.sources.files) files.emplace_back(path.lexically_relative(base).generic_string(), &file.text);
  std::sort(files.begin(), files.end());
  hasher.add("files relative to the pack");
  for (const auto& [path, text] : files) hasher.add(path).add(*text);
}

// Nothing when the front end is unknown (reported).
std::optional<BuildSettings> choose_settings(const BuildOptions& options, const Plan& plan, DiagnosticSink& sink);

// The inputs hash: the tools, options, pack format (a pack another format version wrote is rebuilt) and the
// bytes of every file read.
std::string hash_inputs(const BuildSettings& settings, const Plan& plan);

}  // namespace kiln
