// SPDX-License-Identifier: Apache-2.0
// The files of a variant pack, shared by the writer and the reader: `<name>.manifest.json` and the binary
// archive it names, `<name>.<XXH3-64 of the archive, 16 lower-case hex digits>.kpack`.
//
// Archive layout:
//   offset  size  field
//   0       8     magic "KILNPACK"
//   8       4     format version (kPackFormatVersion), little-endian
//   12      4     blob count N
//   16      8     XXH3-64 of every byte from offset 64 to the end (kiln inspect --verify checks it; a game does not)
//   24      8     total file size
//   32      8     runtime index offset (right after the blob table)
//   40      8     runtime index size
//   48      8     XXH3-64 of the bytes from offset 64 to the index's end: the blob table and the index
//   56      8     zero
//   64      32*N  blob table: {u64 offset, u64 stored size, u64 raw size, u64 XXH3-64 of the raw blob}
//   ...           the runtime index (kiln/runtime_index.hpp)
//   ...           blobs, each starting at a multiple of 8 (zero padding between)
//
// A reader maps the archive and checks the header, the blob table and the index (a few hundred KB) when it opens
// it; each blob's own checksum when the blob is first used. So opening touches the archive's head only, and the
// pages of blobs never used are never read.
//
// Blobs are deduplicated by content; the JSON manifest says which blob is which. A blob whose stored
// size is less than its raw size is exactly one zstd frame that records its content size (= the raw size);
// otherwise the two sizes are equal and the blob is stored as is (kiln compresses a blob only when that
// makes it smaller).
//
// The manifest names the archive ("archive": file, size, XXH3-64, blob count) and carries its own
// checksum: the top-level field "manifest_xxh3_64" holds the XXH3-64 (16 lower-case hex digits) of the
// manifest file's bytes with those 16 digits replaced by '0'. So a manifest edited or damaged after kiln
// wrote it is refused, even where it is still valid JSON (a changed blob id would select another shader).
//
// The manifest's rename is the one step that switches a directory from one pack to the next: the new
// archive is written first under its own name, beside the previous one that the old manifest still names,
// and archives no manifest names are removed only after the rename. A build killed at any point leaves a
// whole pack, the previous or the new one, and at worst an orphaned archive that the next build removes.
//
// Version 5: the runtime index's stage inputs and outputs carry their HLSL semantic. Version 4: the runtime index in the archive (a reader parses no JSON) and a 64-byte header. Version 3: the archive is named by its content (version 2 called it `<name>.kpack`, and renamed it into
// place before the manifest, so a build killed between the two renames broke the previous pack); sizes are
// limited (below). Version 2: the manifest checksum. Version 1 had none.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

namespace kiln {

inline constexpr char kPackMagic[8] = {'K', 'I', 'L', 'N', 'P', 'A', 'C', 'K'};
inline constexpr uint32_t kPackFormatVersion = 5;
inline constexpr uint64_t kPackHeaderSize = 64;
inline constexpr uint64_t kPackBlobEntrySize = 32;
inline constexpr const char* kManifestFormat = "kiln-pack-manifest";
// The manifest checksum's field as it appears in the file: the key, then the 16 hex digits in quotes.
inline constexpr const char* kManifestChecksumField = "\"manifest_xxh3_64\": \"";
inline constexpr unsigned kManifestChecksumDigits = 16;

// Names that become file or directory names (a pack's, a pass's, a scene's: `--emit` and reproducers write under
// pass names) use only these characters, 1 to kMaxNameLength of them, and are not "." or "..": each is a plain name
// inside its directory. One rule, in one place: the definition checks it and the reader checks it again.
inline constexpr std::string_view kPackNameCharacters =
    "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-.";
inline constexpr size_t kMaxNameLength = 128;
// Why `name` cannot be a pack, pass or scene name, or "" when it can.
inline std::string name_problem(std::string_view name) {
  if (name.empty()) return "is empty";
  if (name.size() > kMaxNameLength) return "is longer than " + std::to_string(kMaxNameLength) + " characters";
  if (name.find_first_not_of(kPackNameCharacters) != std::string_view::npos)
    return "may only use letters, digits, '_', '-' and '.'";
  if (name == "." || name == "..") return "is not a file name";
  return "";
}
// A name or value from outside as a message echoes it: at most kMaxEchoedBytes of it (never half a UTF-8
// character), then "... (N bytes)", control characters as \xNN, so that a 3 MiB pack name is one short line.
inline constexpr size_t kMaxEchoedBytes = 64;
inline std::string echoed(std::string_view value, size_t max_bytes = kMaxEchoedBytes) {
  size_t shown = value.size();
  if (shown > max_bytes) {
    shown = max_bytes;
    while (shown > 0 && (static_cast<unsigned char>(value[shown]) & 0xC0) == 0x80) --shown;
  }
  std::string out;
  for (unsigned char c : value.substr(0, shown)) {
    if (c >= 0x20 && c != 0x7f) {
      out.push_back(static_cast<char>(c));
      continue;
    }
    constexpr char kHex[] = "0123456789abcdef";
    out += {'\\', 'x', kHex[c >> 4], kHex[c & 15]};
  }
  if (shown < value.size()) out += "... (" + std::to_string(value.size()) + " bytes)";
  return out;
}
inline constexpr std::string_view kArchiveExtension = ".kpack";

// Limits that the writer keeps and the reader enforces before it allocates, so a damaged or hostile pack
// whose checksums agree still cannot make the reader allocate or read more than this. The default pack's
// largest blob is 30 KB raw, its manifest 1.6 MB and its archive 22 MB (5212 blobs): the limits are far
// above any real pack and far below what would exhaust a game's memory.
inline constexpr uint64_t kMaxBlobBytes = uint64_t{256} << 20;      // raw size of one blob
inline constexpr uint64_t kMaxArchiveBytes = uint64_t{4} << 30;     // the archive file
inline constexpr uint64_t kMaxManifestBytes = uint64_t{256} << 20;  // the manifest file

// `<pack_name>.<archive_xxh3_64>.kpack`, the hash as 16 lower-case hex digits.
inline std::string archive_file_name(std::string_view pack_name, std::string_view archive_xxh3_64) {
  return std::string(pack_name) + "." + std::string(archive_xxh3_64) + std::string(kArchiveExtension);
}

// Whether `file` has the shape of an archive name of pack `pack_name`, whatever its content hash.
inline bool is_archive_file_name(std::string_view file, std::string_view pack_name) {
  constexpr size_t kDigits = 16;
  if (file.size() != pack_name.size() + 1 + kDigits + kArchiveExtension.size() || !file.starts_with(pack_name) ||
      file[pack_name.size()] != '.' || !file.ends_with(kArchiveExtension))
    return false;
  return file.substr(pack_name.size() + 1, kDigits).find_first_not_of("0123456789abcdef") == std::string_view::npos;
}

}  // namespace kiln
