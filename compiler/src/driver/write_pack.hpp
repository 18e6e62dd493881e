// SPDX-License-Identifier: Apache-2.0
// Stage 8: the pack. The archive (named by its content), the manifest (whose rename switches packs), then the
// stamp that lets the next build with the same inputs skip everything.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "driver/plan.hpp"
#include "driver/settings.hpp"
#include "driver/stage_sources.hpp"
#include "kiln/manifest_json.hpp"
#include "pack/pack_writer.hpp"

namespace kiln {

// The archive's file name; nothing when a file could not be written (reported). Binaries and blobs are numbered in
// (pass, variant, stage) order: the same bytes for any -j.
struct WrittenVariantPack {
  std::string archive_file;
  uint64_t unique_binaries = 0;  // distinct optimized SPIR-V: what the pack stores (the funnel's last count)
  PackFiles files;               // the archive's and the manifest's bytes, for the remote cache
};
// `funnel` is the build's so far; the manifest records it with the pack's unique binaries.
[[nodiscard]] std::optional<WrittenVariantPack> write_variant_pack(BuildContext& build, const Plan& plan,
                                                                   const BuildSettings& settings, const StageSources& sources,
                                                                   const std::vector<Binary>& binaries,
                                                                   const std::vector<PassLayout>& layouts,
                                                                   const std::string& inputs_hash, const Funnel& funnel,
                                                                   const std::filesystem::path& output_dir);

}  // namespace kiln
