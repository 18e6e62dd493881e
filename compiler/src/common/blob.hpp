// SPDX-License-Identifier: Apache-2.0
// One output file (a SPIR-V module, a GLSL or MSL source) in the form the pack stores it: a zstd frame when
// that is smaller than the bytes, else the bytes themselves, with the sizes and hashes the pack's index and
// its dedupe need. Workers make them, the cache keeps them and the pack writer copies them: each output is
// compressed once, where it is compiled, and a warm build compresses nothing.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "common/hash.hpp"

struct ZSTD_DCtx_s;  // zstd.h's ZSTD_DCtx

namespace kiln {

struct PackedBlob {
  std::string stored;     // zstd frame (shorter than the bytes) or the bytes (same length)
  uint64_t raw_size = 0;  // length of the bytes
  uint64_t checksum = 0;  // XXH3-64 of the bytes: the pack index's per-blob checksum
  Hash128 key;            // XXH3-128 of the bytes: identical blobs are stored once
  bool compressed() const { return stored.size() < raw_size; }
  friend bool operator==(const PackedBlob&, const PackedBlob&) = default;
};

// zstd level 3, one frame per blob; deterministic for a given zstd version and level.
PackedBlob pack_blob(std::string_view bytes);
PackedBlob pack_spirv(const std::vector<uint32_t>& words);  // little-endian bytes, as the pack stores SPIR-V

// SPIR-V words as little-endian bytes (how the pack and the worker messages carry them) and back; the latter
// throws std::runtime_error when the size is not a multiple of 4.
std::vector<uint8_t> spirv_to_bytes(const std::vector<uint32_t>& words);
std::vector<uint32_t> spirv_from_bytes(std::string_view bytes);

// The bytes back. Throws std::runtime_error when the frame does not decompress to `raw_size` bytes with
// the recorded checksum.
std::string unpack_blob(const PackedBlob& blob);
std::vector<uint32_t> unpack_spirv(const PackedBlob& blob);  // also throws when the size is not 4n

// Whether the blob unpacks to its size, its checksum and its key (XXH3-128), without keeping the bytes: they go to
// `scratch`, which one thread reuses for every blob it checks (no allocation per blob, and one zstd context: making
// one per blob cost as much as the decompression of the default pack's small blobs).
struct BlobScratch {
  BlobScratch();
  ~BlobScratch();
  BlobScratch(const BlobScratch&) = delete;
  BlobScratch& operator=(const BlobScratch&) = delete;
  std::unique_ptr<char[]> bytes;
  size_t capacity = 0;
  ::ZSTD_DCtx_s* context;
};
bool blob_verifies(const PackedBlob& blob, BlobScratch& scratch);

}  // namespace kiln
