// SPDX-License-Identifier: Apache-2.0
// Stage 8: the binary archive (deduplicated blobs, checksummed) and its JSON manifest.
// The archive first, under a name of its own, then the manifest, each through temp + rename: the manifest's
// rename is the commit point (kiln/pack_format.hpp), so a failed or killed build leaves the previous pack intact.
#pragma once

#include <deque>
#include <filesystem>
#include <map>
#include <memory>
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
  // The same without a copy: `blob` must outlive the builder (a build's outputs, which the pack writer holds).
  uint32_t add_borrowed(const PackedBlob& blob);
  size_t size() const { return blobs_.size(); }
  const std::vector<const PackedBlob*>& blobs() const { return blobs_; }
  // The archive file (kiln/pack_format.hpp): the blobs in the order added, after the runtime index `index`.
  std::string finish(std::string_view index) const;
  // The same bytes as parts, without joining them: the head (header, blob table, index), then each blob's padding and
  // bytes, views of the blobs (valid while the blobs are: a borrowed blob's owner, the builder for the others).
  struct Parts {
    std::unique_ptr<std::string> head;  // where parts.front() points, wherever Parts moves
    std::vector<std::string_view> parts;
    uint64_t size = 0;
  };
  Parts finish_parts(std::string_view index) const;

 private:
  std::vector<const PackedBlob*> blobs_;
  std::deque<PackedBlob> owned_;  // those added by value
  std::map<Hash128, uint32_t> by_hash_;
};

// Writes the archive under its content's name, then `<dir>/<name>.manifest.json` naming it (the rename that
// switches the pack), then removes the pack's archives the manifest no longer names; fills manifest.archive.
// Returns the archive's file name, `<name>.<XXH3-64>.kpack`. One output directory serves one build at a time: a
// concurrent build of the same pack could lose its archive.
// `files`, when given, gets the two files' bytes (the remote cache uploads them without reading them back): the
// archive as the builder's parts (valid while its blobs are).
struct PackFiles {
  ArchiveBuilder::Parts archive;
  std::string manifest;
};
Result<std::string> write_pack(const std::filesystem::path& directory, const std::string& name, const ArchiveBuilder& archive,
                               Manifest manifest, PackFiles* files = nullptr);

// Removes the archives of pack `name` in `directory` other than `keep`: those a build killed before its
// manifest's rename, or before the removal itself, left behind (and `<name>.kpack`, from format version 2).
void remove_orphaned_archives(const std::filesystem::path& directory, const std::string& name, const std::string& keep);

std::filesystem::path manifest_path(const std::filesystem::path& directory, const std::string& name);

}  // namespace kiln
