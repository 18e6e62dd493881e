// Stage 8: the binary archive (deduplicated blobs, checksummed) and its JSON manifest.
// Archive first, manifest last, each through temp + rename: a reader never sees a manifest that
// points at a missing or older archive, and a failed build leaves the previous pack intact.
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/hash.hpp"
#include "pack/blob.hpp"

namespace kiln {

class ArchiveBuilder {
 public:
  // Returns the blob id; identical bytes get the same id. Blobs come packed (compressed where they were
  // compiled); add(bytes) packs them here.
  uint32_t add(PackedBlob blob);
  uint32_t add(std::string_view bytes);
  size_t size() const { return blobs_.size(); }
  std::string finish() const;  // blobs in the order added

 private:
  std::vector<PackedBlob> blobs_;
  std::map<Hash128, uint32_t> by_hash_;
};

// Writes `<dir>/<name>.kpack` and `<dir>/<name>.manifest.json`; fills manifest["archive"].
// Returns an error message, or an empty string.
std::string write_pack(const std::filesystem::path& directory, const std::string& name, const ArchiveBuilder& archive,
                       nlohmann::json manifest);

std::filesystem::path manifest_path(const std::filesystem::path& directory, const std::string& name);

}  // namespace kiln
