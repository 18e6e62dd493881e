#include "pack/pack_writer.hpp"

#include "common/files.hpp"
#include "kiln/pack_format.hpp"

#include <cstring>

namespace kiln {
namespace {

void put32(std::string& out, uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<char>(v >> (8 * i)));
}
void put64(std::string& out, uint64_t v) {
  for (int i = 0; i < 8; ++i) out.push_back(static_cast<char>(v >> (8 * i)));
}
void set64(std::string& out, size_t at, uint64_t v) {
  for (int i = 0; i < 8; ++i) out[at + i] = static_cast<char>(v >> (8 * i));
}

}  // namespace

uint32_t ArchiveBuilder::add(PackedBlob blob) {
  if (auto it = by_hash_.find(blob.key); it != by_hash_.end()) return it->second;
  uint32_t id = static_cast<uint32_t>(blobs_.size());
  by_hash_.emplace(blob.key, id);
  blobs_.push_back(std::move(blob));
  return id;
}

uint32_t ArchiveBuilder::add(std::string_view bytes) { return add(pack_blob(bytes)); }

std::string ArchiveBuilder::finish() const {
  std::string out(kPackMagic, 8);
  put32(out, kPackFormatVersion);
  put32(out, static_cast<uint32_t>(blobs_.size()));
  put64(out, 0);  // checksum, filled below
  put64(out, 0);  // total size, filled below
  uint64_t offset = kPackHeaderSize + kPackBlobEntrySize * blobs_.size();
  for (const PackedBlob& blob : blobs_) {
    offset = (offset + 7) & ~uint64_t{7};
    put64(out, offset);
    put64(out, blob.stored.size());
    put64(out, blob.raw_size);
    put64(out, blob.checksum);
    offset += blob.stored.size();
  }
  out.reserve(offset);
  for (const PackedBlob& blob : blobs_) {
    out.append(((out.size() + 7) & ~size_t{7}) - out.size(), '\0');
    out += blob.stored;
  }
  set64(out, 24, out.size());
  set64(out, 16, hash64(std::string_view(out).substr(kPackHeaderSize)));
  return out;
}

std::filesystem::path manifest_path(const std::filesystem::path& directory, const std::string& name) {
  return directory / (name + ".manifest.json");
}

std::string write_pack(const std::filesystem::path& directory, const std::string& name, const ArchiveBuilder& archive,
                       nlohmann::json manifest) {
  std::string bytes = archive.finish();
  const std::string archive_name = name + ".kpack";
  manifest["archive"] = {{"file", archive_name}, {"size", bytes.size()}, {"xxh3_64", hex64(hash64(bytes))},
                         {"blobs", archive.size()}};
  manifest["manifest_xxh3_64"] = std::string(kManifestChecksumDigits, '0');
  if (std::string error = write_file_atomic(directory / archive_name, bytes); !error.empty()) return error;
  // Indented one level per nesting would make the manifest ~3x larger; one line per binary is still diffable.
  std::string text = manifest.dump(1) + "\n";
  // The checksum covers the text with its own digits zeroed (pack_format.hpp). Only a top-level key can be
  // followed by `": "` outside a string, and kiln writes this key nowhere else.
  const size_t field = text.find(kManifestChecksumField);
  text.replace(field + std::strlen(kManifestChecksumField), kManifestChecksumDigits, hex64(hash64(text)));
  return write_file_atomic(manifest_path(directory, name), text);
}

}  // namespace kiln
