// SPDX-License-Identifier: Apache-2.0
#include "pack/pack_writer.hpp"

#include "common/files.hpp"
#include "kiln/pack_format.hpp"
#include "kiln/runtime_index.hpp"

#include <csignal>
#include <cstdlib>
#include <cstring>

namespace kiln {
namespace {

// Test-only fault injection, enabled by KILN_PACK_FAULT_INJECTION=<point>: at that point of write_pack the
// process is killed (SIGKILL: nothing is cleaned up), as a crash or a `kill -9` at the worst moment would.
// Points: "kill-after-archive" (the new archive is in place, the manifest not yet renamed) and
// "kill-after-manifest" (the manifest renamed, the archives it no longer names not yet removed).
void inject_fault(const char* point) {
  const char* env = std::getenv("KILN_PACK_FAULT_INJECTION");
  if (env && std::strcmp(env, point) == 0) std::raise(SIGKILL);
}

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
  return add_borrowed(owned_.emplace_back(std::move(blob)));
}

uint32_t ArchiveBuilder::add_borrowed(const PackedBlob& blob) {
  auto [it, fresh] = by_hash_.emplace(blob.key, static_cast<uint32_t>(blobs_.size()));
  if (fresh) blobs_.push_back(&blob);
  return it->second;
}

uint32_t ArchiveBuilder::add(std::string_view bytes) { return add(pack_blob(bytes)); }

ArchiveBuilder::Parts ArchiveBuilder::finish_parts(std::string_view index) const {
  static constexpr char kPadding[8] = {};
  Parts out;
  out.head = std::make_unique<std::string>();
  std::string& head = *out.head;
  head.assign(kPackMagic, 8);
  put32(head, kPackFormatVersion);
  put32(head, static_cast<uint32_t>(blobs_.size()));
  put64(head, 0);  // checksum, filled below
  put64(head, 0);  // total size, filled below
  const uint64_t index_offset = kPackHeaderSize + kPackBlobEntrySize * blobs_.size();
  put64(head, index_offset);
  put64(head, index.size());
  put64(head, 0);  // the head's checksum, filled below
  put64(head, 0);
  uint64_t offset = index_offset + index.size();
  out.parts.reserve(2 * blobs_.size() + 1);
  out.parts.emplace_back();  // the head, once it is whole
  for (const PackedBlob* blob : blobs_) {
    const uint64_t aligned = (offset + 7) & ~uint64_t{7};
    if (aligned > offset) out.parts.emplace_back(kPadding, aligned - offset);
    out.parts.emplace_back(blob->stored);
    put64(head, aligned);
    put64(head, blob->stored.size());
    put64(head, blob->raw_size);
    put64(head, blob->checksum);
    offset = aligned + blob->stored.size();
  }
  head += index;
  out.size = offset;
  set64(head, 24, out.size);
  set64(head, 48, hash64(std::string_view(head).substr(kPackHeaderSize)));
  // The checksum of everything after the header: the rest of the head, then the blobs.
  out.parts.front() = std::string_view(head).substr(kPackHeaderSize);
  set64(head, 16, hash64(out.parts));
  out.parts.front() = head;
  return out;
}

std::string ArchiveBuilder::finish(std::string_view index) const {
  const Parts parts = finish_parts(index);
  std::string out;
  out.reserve(parts.size);
  for (std::string_view part : parts.parts) out += part;
  return out;
}

std::filesystem::path manifest_path(const std::filesystem::path& directory, const std::string& name) {
  return directory / (name + ".manifest.json");
}

Result<std::string> write_pack(const std::filesystem::path& directory, const std::string& name, const ArchiveBuilder& archive,
                               Manifest manifest, PackFiles* files) {
  for (const PackedBlob* blob : archive.blobs())
    if (blob->raw_size > kMaxBlobBytes) {
      return failure("an output of " + std::to_string(blob->raw_size) + " bytes is over the pack format's limit of " +
                     std::to_string(kMaxBlobBytes) + " bytes per blob");
    }
  ArchiveBuilder::Parts bytes = archive.finish_parts(runtime::encode(manifest));
  if (bytes.size > kMaxArchiveBytes) {
    return failure("the archive would be " + std::to_string(bytes.size) + " bytes, over the pack format's limit of " +
                   std::to_string(kMaxArchiveBytes) + " bytes");
  }
  const std::string archive_hash = hex64(hash64(bytes.parts));
  const std::string archive_file = archive_file_name(name, archive_hash);
  manifest.archive = {archive_file, bytes.size, archive_hash, archive.size()};
  nlohmann::json file = manifest;
  file["manifest_xxh3_64"] = std::string(kManifestChecksumDigits, '0');
  // Indented one level per nesting would make the manifest ~3x larger; one line per binary is still diffable.
  std::string text = file.dump(1) + "\n";
  if (text.size() > kMaxManifestBytes) {
    return failure("the manifest would be " + std::to_string(text.size()) + " bytes, over the pack format's limit of " +
                   std::to_string(kMaxManifestBytes) + " bytes");
  }
  // The checksum covers the text with its own digits zeroed (pack_format.hpp). Only a top-level key can be
  // followed by `": "` outside a string, and kiln writes this key nowhere else.
  const size_t field = text.find(kManifestChecksumField);
  text.replace(field + std::strlen(kManifestChecksumField), kManifestChecksumDigits, hex64(hash64(text)));

  // The previous manifest names another archive (or this one, when the content is the same: then the rename
  // replaces it with the same bytes), so until the manifest's rename below the previous pack is whole.
  if (Result<void> written = write_output_file(directory / archive_file, bytes.parts); !written) return failure(written.error());
  inject_fault("kill-after-archive");
  // On failure the new archive is left for the next build to remove: with the same content, it is the previous pack's.
  if (Result<void> written = write_output_file(manifest_path(directory, name), text); !written) return failure(written.error());
  inject_fault("kill-after-manifest");
  remove_orphaned_archives(directory, name, archive_file);
  if (files) *files = {std::move(bytes), std::move(text)};
  return archive_file;
}

void remove_orphaned_archives(const std::filesystem::path& directory, const std::string& name, const std::string& keep) {
  std::error_code ec;
  std::vector<std::filesystem::path> orphans;
  for (std::filesystem::directory_iterator it(directory, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string file = it->path().filename().string();
    if (file != keep && (is_archive_file_name(file, name) || file == name + std::string(kArchiveExtension)))
      orphans.push_back(it->path());
  }
  // Removing one that is already gone, or cannot be removed, costs disk space only: the pack is whole.
  for (const auto& orphan : orphans) std::filesystem::remove(orphan, ec);
}

}  // namespace kiln
