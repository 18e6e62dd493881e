// Stage 8: the binary archive (deduplicated blobs, checksummed) and its JSON manifest.
// The archive first, under a name of its own, then the manifest, each through temp + rename: the manifest's
// rename is the commit point (kiln/pack_format.hpp), so a failed or killed build leaves the previous pack intact.
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "common/hash.hpp"
#include "common/blob.hpp"
#include "kiln/manifest_json.hpp"
#include "kiln/result.hpp"

namespace kiln {

class ArchiveBuilder {
 public:
  // Returns the blob id; identical bytes get the same id. Blobs come packed (compressed where they were
  // compiled); add(bytes) packs them here.
  uint32_t add(PackedBlob blob);
  uint32_t add(std::string_view bytes);
  size_t size() const { return blobs_.size(); }
  const std::vector<PackedBlob>& blobs() const { return blobs_; }
  // The archive file (kiln/pack_format.hpp): the blobs in the order added, after the runtime index `index`.
  std::string finish(std::string_view index) const;

 private:
  std::vector<PackedBlob> blobs_;
  std::map<Hash128, uint32_t> by_hash_;
};

// Writes the archive under its content's name, then `<dir>/<name>.manifest.json` naming it (the rename that
// switches the pack), then removes the pack's archives the manifest no longer names; fills manifest.archive.
// Returns the archive's file name, `<name>.<XXH3-64>.kpack`. One output directory serves one build at a time: a
// concurrent build of the same pack could lose its archive.
Result<std::string> write_pack(const std::filesystem::path& directory, const std::string& name, const ArchiveBuilder& archive,
                       Manifest manifest);

// Removes the archives of pack `name` in `directory` other than `keep`: those a build killed before its
// manifest's rename, or before the removal itself, left behind (and `<name>.kpack`, from format version 2).
void remove_orphaned_archives(const std::filesystem::path& directory, const std::string& name, const std::string& keep);

std::filesystem::path manifest_path(const std::filesystem::path& directory, const std::string& name);

}  // namespace kiln
