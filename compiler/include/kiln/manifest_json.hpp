// SPDX-License-Identifier: Apache-2.0
// The manifest's JSON conversions: nlohmann-json's customisation points for the types of manifest.hpp. For the
// compiler, its tools and tests; not installed, so that a game including the reader's headers (manifest.hpp,
// pack_reader.hpp, kiln_reader.h) does not need nlohmann-json. Implemented in src/reader/manifest.cpp.
//
// from_json refuses what kiln does not write (a missing field, a wrong type, a negative or oversized number, an
// unknown stage or target) with ManifestError, which names the place as a JSON pointer; unknown fields are
// ignored.
#pragma once

#include <nlohmann/json.hpp>

#include "kiln/manifest.hpp"

namespace kiln {

void to_json(nlohmann::json& j, const BlockMember& v);
void from_json(const nlohmann::json& j, BlockMember& v);
void to_json(nlohmann::json& j, const Resource& v);
void from_json(const nlohmann::json& j, Resource& v);
void to_json(nlohmann::json& j, const PushConstantBlock& v);
void from_json(const nlohmann::json& j, PushConstantBlock& v);
void to_json(nlohmann::json& j, const StageVariable& v);
void from_json(const nlohmann::json& j, StageVariable& v);
void to_json(nlohmann::json& j, const GlCombinedSampler& v);
void from_json(const nlohmann::json& j, GlCombinedSampler& v);
void to_json(nlohmann::json& j, const GlBlock& v);
void from_json(const nlohmann::json& j, GlBlock& v);
void to_json(nlohmann::json& j, const GlBindings& v);
void from_json(const nlohmann::json& j, GlBindings& v);
void to_json(nlohmann::json& j, const MslResource& v);
void from_json(const nlohmann::json& j, MslResource& v);
void to_json(nlohmann::json& j, const MslBindings& v);
void from_json(const nlohmann::json& j, MslBindings& v);
void to_json(nlohmann::json& j, const Reflection& v);
void from_json(const nlohmann::json& j, Reflection& v);
void to_json(nlohmann::json& j, const PassLayout& v);
void from_json(const nlohmann::json& j, PassLayout& v);
void to_json(nlohmann::json& j, const ManifestKeywordGroup& v);
void from_json(const nlohmann::json& j, ManifestKeywordGroup& v);
void to_json(nlohmann::json& j, const ManifestVariant& v);
void from_json(const nlohmann::json& j, ManifestVariant& v);
void to_json(nlohmann::json& j, const ManifestPass& v);
void from_json(const nlohmann::json& j, ManifestPass& v);
void to_json(nlohmann::json& j, const ManifestBinary& v);
void from_json(const nlohmann::json& j, ManifestBinary& v);
void to_json(nlohmann::json& j, const ManifestConstraint& v);
void from_json(const nlohmann::json& j, ManifestConstraint& v);
void to_json(nlohmann::json& j, const ManifestMaterial& v);
void from_json(const nlohmann::json& j, ManifestMaterial& v);
void to_json(nlohmann::json& j, const ManifestTools& v);
void from_json(const nlohmann::json& j, ManifestTools& v);
void to_json(nlohmann::json& j, const ManifestOptions& v);
void from_json(const nlohmann::json& j, ManifestOptions& v);
void to_json(nlohmann::json& j, const ManifestFunnel& v);
void from_json(const nlohmann::json& j, ManifestFunnel& v);
void to_json(nlohmann::json& j, const ManifestArchive& v);
void from_json(const nlohmann::json& j, ManifestArchive& v);
// The manifest's "format" field and checksum are the file's, not the model's: the writer adds them
// (pack_writer.cpp) and the reader checks them before from_json (pack_reader.cpp).
void to_json(nlohmann::json& j, const Manifest& v);
void from_json(const nlohmann::json& j, Manifest& v);

}  // namespace kiln
