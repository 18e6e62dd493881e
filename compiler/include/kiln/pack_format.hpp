// The binary archive of a variant pack (`<name>.kpack`), shared by the writer and the reader.
//
//   offset  size  field
//   0       8     magic "KILNPACK"
//   8       4     format version (kPackFormatVersion), little-endian
//   12      4     blob count N
//   16      8     XXH3-64 of every byte from offset 32 to the end
//   24      8     total file size
//   32      32*N  blob table: {u64 offset, u64 stored size, u64 raw size, u64 XXH3-64 of the raw blob}
//   ...           blobs, each starting at a multiple of 8 (zero padding between)
//
// Blobs are deduplicated by content; the JSON manifest says which blob is which. A blob whose stored
// size differs from its raw size is one zstd frame; otherwise it is stored as is (kiln compresses a
// blob only when that makes it smaller).
//
// The manifest (`<name>.manifest.json`) names the archive with its size and XXH3-64, and carries its own
// checksum: the top-level field "manifest_xxh3_64" holds the XXH3-64 (16 lower-case hex digits) of the
// manifest file's bytes with those 16 digits replaced by '0'. So a manifest edited or damaged after kiln
// wrote it is refused, even where it is still valid JSON (a changed blob id would select another shader).
//
// Version 2: the manifest checksum. Version 1 had none.
#pragma once

#include <cstdint>

namespace kiln {

inline constexpr char kPackMagic[8] = {'K', 'I', 'L', 'N', 'P', 'A', 'C', 'K'};
inline constexpr uint32_t kPackFormatVersion = 2;
inline constexpr uint64_t kPackHeaderSize = 32;
inline constexpr uint64_t kPackBlobEntrySize = 32;
inline constexpr const char* kManifestFormat = "kiln-pack-manifest";
// The manifest checksum's field as it appears in the file: the key, then the 16 hex digits in quotes.
inline constexpr const char* kManifestChecksumField = "\"manifest_xxh3_64\": \"";
inline constexpr unsigned kManifestChecksumDigits = 16;

}  // namespace kiln
