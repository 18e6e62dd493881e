// SPDX-License-Identifier: Apache-2.0
// The shared remote cache in a build (remote/; docs/remote-cache.md): its pack-level entry before any work, and the
// keys of its stage-source and module entries (the result store's remote tier, driver/result_store).
#pragma once

#include <memory>
#include <optional>
#include <string>

#include "driver/plan.hpp"
#include "driver/settings.hpp"
#include "remote/remote_cache.hpp"

namespace kiln {

// The key of the pack-level entry: the same fields as the inputs hash, and the pack's name.
RemoteKey remote_pack_key(const RemoteCache& remote, const BuildSettings& settings, const Plan& plan);

// The finished pack of these inputs, when a machine with the same checkout built it: written into the output
// directory with its stamp (the next build is up to date). False when the remote does not have it.
bool fetch_remote_pack(RemoteCache& remote, const RemoteKey& key, const std::filesystem::path& output_dir,
                       const Plan& plan, const std::string& inputs_hash, DiagnosticSink& sink);

// The remote key of a stage source (kind "source") or of a front-end module (kind "module").
RemoteKey remote_source_key(const RemoteCache& remote, const BuildSettings& settings, const PassDefinition& pass,
                            Stage stage, std::string_view text);
RemoteKey remote_module_key(const RemoteCache& remote, const BuildSettings& settings, const PassDefinition& pass,
                            Stage stage, const std::vector<uint32_t>& spirv);

}  // namespace kiln
