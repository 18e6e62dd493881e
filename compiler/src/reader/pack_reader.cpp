#include "kiln/pack_reader.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <xxhash.h>
#include <zstd.h>

#include <algorithm>
#include <cerrno>
#include <functional>
#include <cstdlib>
#include <new>
#include <cstring>
#include <optional>
#include <set>

#include "kiln/bounded_json.hpp"
#include "kiln/manifest_json.hpp"
#include "kiln/pack_format.hpp"

namespace kiln {
namespace {

using nlohmann::json;

// Reads a pack file whole: a regular file only (a FIFO would block, a device never end), checked before it is
// opened and again on the opened descriptor (opened without blocking, so a file swapped for a FIFO in between
// cannot block either); its size checked against `expected` (the manifest's record) and `limit` before a byte
// is read or a buffer made. `what` names the file in messages ("the manifest"). `check_header`, if given, sees the
// file's first `header_size` bytes (fewer if the file is shorter) before the buffer for the whole file is made.
std::string read_pack_file(const std::string& path, const std::string& what, uint64_t limit,
                           std::optional<uint64_t> expected = std::nullopt,
                           const std::function<void(std::string_view)>& check_header = {}, size_t header_size = 0) {
  auto system_error = [&](const char* doing) {
    const int error = errno;
    return PackError(PackError::Code::Io,
                     error == ENOENT ? std::string("no such file or directory")
                                     : doing + std::string(": ") + std::strerror(error),
                     path);
  };
  auto check_type = [&](const struct stat& info) {
    if (S_ISREG(info.st_mode)) return;
    const char* kind = S_ISDIR(info.st_mode) ? "a directory" : S_ISFIFO(info.st_mode) ? "a FIFO" : "a device or socket";
    throw PackError(PackError::Code::Io, std::string(kind) + ", not a regular file", path);
  };
  struct stat info {};
  if (::stat(path.c_str(), &info) != 0) throw system_error("cannot open the file");
  check_type(info);
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) throw system_error("cannot open the file");
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  if (::fstat(fd, &info) != 0) throw system_error("cannot read the file");
  check_type(info);
  const uint64_t size = static_cast<uint64_t>(info.st_size);
  if (expected && size != *expected)
    throw PackError(PackError::Code::Checksum,
                    what + " is " + std::to_string(size) + " bytes, not the " + std::to_string(*expected) +
                        " its manifest records",
                    path);
  if (size > limit)
    throw PackError(PackError::Code::Format,
                    what + " is " + std::to_string(size) + " bytes, over the pack format's limit of " +
                        std::to_string(limit) + " bytes",
                    path);
  auto read_into = [&](char* buffer, size_t want) {
    size_t got = 0;
    while (got < want) {
      const ssize_t n = ::read(fd, buffer + got, want - got);
      if (n < 0 && errno == EINTR) continue;
      if (n < 0) throw system_error("cannot read the file");
      if (n == 0) break;
      got += static_cast<size_t>(n);
    }
    if (got != want) throw PackError(PackError::Code::Checksum, what + " was truncated while it was read", path);
  };
  std::string header;
  if (check_header) {
    header.resize(static_cast<size_t>(std::min<uint64_t>(size, header_size)));
    read_into(header.data(), header.size());
    check_header(header);
  }
  std::string bytes(size, '\0');
  std::memcpy(bytes.data(), header.data(), header.size());
  read_into(bytes.data() + header.size(), bytes.size() - header.size());
  return bytes;
}

uint64_t get64(const std::string& bytes, size_t at) {
  uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v |= static_cast<uint64_t>(static_cast<unsigned char>(bytes[at + i])) << (8 * i);
  return v;
}

std::string hex64(uint64_t value) {
  char text[17];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(value));
  return text;
}

// "file:line:col" of a byte offset in `text` (both 1-based).
std::string location_of(const std::filesystem::path& file, const std::string& text, size_t offset) {
  offset = std::min(offset, text.size());
  size_t line = 1 + static_cast<size_t>(std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(offset), '\n'));
  size_t line_start = text.rfind('\n', offset == 0 ? std::string::npos : offset - 1);
  size_t column = offset - (line_start == std::string::npos ? 0 : line_start + 1) + 1;
  return file.string() + ":" + std::to_string(line) + ":" + std::to_string(column);
}

std::string join(const std::vector<std::string>& words) {
  std::string out;
  for (const std::string& w : words) out += (out.empty() ? "" : " ") + w;
  return out.empty() ? "<none>" : out;
}

}  // namespace

const StageView* SelectedVariant::stage(std::string_view name) const {
  for (const StageView& s : stages)
    if (s.stage == name) return &s;
  return nullptr;
}

namespace {

// The manifest's own checksum (pack_format.hpp): found in the text, checked against the text with its
// digits zeroed (in place, then put back: no copy of a manifest that may be large). It runs before the text is
// parsed, so a damaged or foreign manifest costs one hash of its bytes, never a JSON tree.
void check_manifest_checksum(std::string& text, const std::string& manifest_name) {
  const size_t field = text.find(kManifestChecksumField);
  const size_t digits = field + std::strlen(kManifestChecksumField);
  if (field == std::string::npos || text.find(kManifestChecksumField, digits) != std::string::npos ||
      text.size() < digits + kManifestChecksumDigits)
    throw PackError(PackError::Code::Format, "not a kiln pack manifest: it has no checksum (\"manifest_xxh3_64\")",
                    manifest_name);
  const std::string stored = text.substr(digits, kManifestChecksumDigits);
  text.replace(digits, kManifestChecksumDigits, kManifestChecksumDigits, '0');
  const std::string computed = hex64(XXH3_64bits(text.data(), text.size()));
  text.replace(digits, kManifestChecksumDigits, stored);
  if (stored != computed)
    throw PackError(PackError::Code::Checksum, "the manifest fails its checksum (changed since kiln wrote it)",
                    manifest_name);
}

}  // namespace

PackReader PackReader::open(const std::filesystem::path& path) {
  try {
    return open_checked(path);
  } catch (const std::bad_alloc&) {
    throw PackError(PackError::Code::OutOfMemory, "the pack does not fit in the memory this process may use", path.string());
  }
}

PackReader PackReader::open_checked(const std::filesystem::path& path) {
  std::filesystem::path manifest_file = path;
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    std::vector<std::filesystem::path> found;
    for (std::filesystem::directory_iterator it(path, ec), end; !ec && it != end; it.increment(ec))
      if (it->path().string().ends_with(".manifest.json")) found.push_back(it->path());
    if (found.size() != 1)
      throw PackError(PackError::Code::Io, "the directory holds " + std::to_string(found.size()) +
                                               " pack manifests (*.manifest.json); name the manifest file",
                      path.string());
    manifest_file = found[0];
  }
  PackReader reader;
  const std::string manifest_name = manifest_file.string();
  std::string text = read_pack_file(manifest_name, "the manifest", kMaxManifestBytes);
  // Sizes, then the checksum, then the parse: what is parsed is what kiln wrote, bounded in depth.
  check_manifest_checksum(text, manifest_name);
  // nlohmann's tree takes up to about 20 bytes per byte of text (17x measured on a 250 MiB manifest), and a parse
  // that runs out of memory half-way can end the process (the tree's destructor allocates). So the room is asked
  // for first: under an address-space limit a manifest too large for it is std::bad_alloc here (the C API's
  // KILN_ERROR_OUT_OF_MEMORY), before the parse starts.
  if (text.size() > (size_t{1} << 20)) {
    void* volatile room = std::malloc(text.size() * 24);  // volatile: the compiler may not drop the pair
    if (!room) throw std::bad_alloc();
    std::free(room);
  }
  json m;
  try {
    m = parse_json_bounded(text, {kMaxManifestBytes, kMaxJsonDepth});
  } catch (const JsonDecodeError& error) {
    throw PackError(PackError::Code::Format, std::string("not a kiln manifest: invalid JSON: ") + error.what(),
                    location_of(manifest_file, text, error.offset()));
  }
  const json no_value;
  auto top = [&](const char* key) -> const json& {
    if (!m.is_object()) return no_value;
    auto it = m.find(key);
    return it == m.end() ? no_value : *it;
  };
  if (top("format") != kManifestFormat)
    throw PackError(PackError::Code::Format, "not a kiln pack manifest (no \"format\": \"" + std::string(kManifestFormat) + "\")",
                    manifest_name);
  const json& format_version = top("format_version");
  if (!format_version.is_number_unsigned() || format_version.get<uint64_t>() != kPackFormatVersion)
    throw PackError(PackError::Code::Version,
                    (format_version.is_null()     ? std::string("the manifest has no format_version")
                     : format_version.is_primitive() ? "pack format version " + format_version.dump() + " is not supported"
                                                     : std::string("the manifest's format_version is not a number")) +
                        " (this reader reads version " + std::to_string(kPackFormatVersion) + ")",
                    manifest_name);
  text = std::string();  // the tree is all that is needed now
  auto malformed = [&](const std::string& what) {
    return PackError(PackError::Code::Format, "malformed manifest: " + what, manifest_name);
  };
  try {
    reader.manifest_ = m.get<Manifest>();
  } catch (const ManifestError& error) {
    throw malformed(error.what());
  }
  m = json();  // the typed manifest is all that is kept
  const Manifest& manifest = reader.manifest_;
  reader.name_ = manifest.name;
  // The manifest names the archive; a name of any other shape ("../x", "/etc/passwd") is refused before any
  // file is opened, so a hostile manifest can make the reader read nothing but this pack's own archive.
  if (std::string problem = name_problem(reader.name_); !problem.empty())
    throw malformed("/name: " + json(reader.name_).dump() + " is not a pack name: it " + problem);
  const std::string& archive_name = manifest.archive.file;
  if (archive_name != archive_file_name(reader.name_, manifest.archive.xxh3_64) || !is_archive_file_name(archive_name, reader.name_))
    throw malformed("/archive/file: " + json(archive_name).dump() + " is not the archive's name, <name>.<xxh3_64>" +
                    std::string(kArchiveExtension));
  reader.archive_file_ = (manifest_file.parent_path() / archive_name).string();
  auto fail = [&](PackError::Code code, const std::string& message) { throw PackError(code, message, reader.archive_file_); };
  uint32_t count = 0;
  // The 32-byte header is checked (magic, version, the size it records) before the rest of the archive is read.
  auto check_header = [&](std::string_view header) {
    const std::string head(header);
    if (head.size() < kPackHeaderSize || std::memcmp(head.data(), kPackMagic, 8) != 0)
      fail(PackError::Code::Format, "archive of pack '" + reader.name_ + "' has no KILNPACK header");
    uint32_t version = 0;
    std::memcpy(&version, head.data() + 8, 4);
    std::memcpy(&count, head.data() + 12, 4);
    if (version != kPackFormatVersion)
      fail(PackError::Code::Version, "archive format version " + std::to_string(version) + " is not supported");
    if (get64(head, 24) != manifest.archive.size)
      fail(PackError::Code::Checksum, "archive of pack '" + reader.name_ + "' is truncated or has the wrong size");
  };
  reader.archive_ = read_pack_file(reader.archive_file_, "archive of pack '" + reader.name_ + "'", kMaxArchiveBytes,
                                   manifest.archive.size, check_header, kPackHeaderSize);
  const std::string& bytes = reader.archive_;
  if (XXH3_64bits(bytes.data() + kPackHeaderSize, bytes.size() - kPackHeaderSize) != get64(bytes, 16) ||
      hex64(XXH3_64bits(bytes.data(), bytes.size())) != manifest.archive.xxh3_64)
    fail(PackError::Code::Checksum, "archive of pack '" + reader.name_ + "' fails its checksum");
  if (kPackHeaderSize + kPackBlobEntrySize * uint64_t{count} > bytes.size())
    fail(PackError::Code::Format, "archive blob table is out of bounds");
  if (count != manifest.archive.blobs)
    throw malformed("/archive/blobs: " + std::to_string(manifest.archive.blobs) + " blobs, the archive holds " +
                    std::to_string(count));
  reader.blobs_.reserve(count);
  for (uint32_t i = 0; i < count; ++i) {
    size_t at = kPackHeaderSize + kPackBlobEntrySize * i;
    Blob blob{get64(bytes, at), get64(bytes, at + 8), get64(bytes, at + 16), get64(bytes, at + 24)};
    const std::string which = "blob " + std::to_string(i);
    if (blob.offset > bytes.size() || blob.stored_size > bytes.size() - blob.offset)
      fail(PackError::Code::Format, which + " is out of bounds");
    if (blob.raw_size > kMaxBlobBytes)
      fail(PackError::Code::Format, which + ": raw size " + std::to_string(blob.raw_size) +
                                        " is over the pack format's limit of " + std::to_string(kMaxBlobBytes) + " bytes");
    if (blob.stored_size > blob.raw_size)
      fail(PackError::Code::Format, which + ": stored size " + std::to_string(blob.stored_size) +
                                        " is larger than its raw size " + std::to_string(blob.raw_size));
    const char* stored = bytes.data() + blob.offset;
    if (blob.stored_size == blob.raw_size) {
      if (XXH3_64bits(stored, blob.stored_size) != blob.hash) fail(PackError::Code::Checksum, which + " fails its checksum");
    } else {
      // A frame is decompressed (and its checksum checked) when it is first read; its sizes are checked now, so
      // that the buffer made then is only as large as the frame can fill.
      const size_t frame_size = ZSTD_findFrameCompressedSize(stored, blob.stored_size);
      if (ZSTD_isError(frame_size) || frame_size != blob.stored_size) fail(PackError::Code::Format, which + " is not one zstd frame");
      const unsigned long long content_size = ZSTD_getFrameContentSize(stored, blob.stored_size);
      if (content_size == ZSTD_CONTENTSIZE_UNKNOWN || content_size == ZSTD_CONTENTSIZE_ERROR)
        fail(PackError::Code::Format, which + ": its zstd frame does not record its size");
      if (content_size != blob.raw_size)
        fail(PackError::Code::Format, which + ": its zstd frame holds " + std::to_string(content_size) +
                                          " bytes, the blob table records " + std::to_string(blob.raw_size));
      // A frame's header may claim any size; no frame fills more than one 128 KiB block per 4 of its bytes
      // (a 3-byte block header and 1 byte repeated), so a larger claim is refused before it is allocated.
      if (blob.raw_size / ZSTD_BLOCKSIZE_MAX > blob.stored_size / 4)
        fail(PackError::Code::Format, which + ": a zstd frame of " + std::to_string(blob.stored_size) +
                                          " bytes cannot hold " + std::to_string(blob.raw_size));
    }
    reader.blobs_.push_back(blob);
  }
  try {
    manifest.check_indices();
  } catch (const ManifestError& error) {
    throw malformed(error.what());
  }
  for (const ManifestPass& pass : manifest.passes) {
    Pass entry;
    entry.manifest = &pass;
    for (const ManifestKeywordGroup& group : pass.keyword_groups) entry.groups.push_back(group.values);
    for (size_t i = 0; i < pass.variants.size(); ++i) entry.by_key[join(pass.variants[i].keywords)] = i;
    if (!reader.passes_.emplace(pass.name, std::move(entry)).second)
      throw malformed("/passes: two passes are named " + json(pass.name).dump());
  }
  return reader;
}

std::vector<std::string> PackReader::passes() const {
  std::vector<std::string> names;
  for (const ManifestPass& pass : manifest_.passes) names.push_back(pass.name);
  return names;
}

const PackReader::Pass& PackReader::find_pass(std::string_view name) const {
  auto it = passes_.find(name);
  if (it == passes_.end())
    throw PackError(PackError::Code::UnknownPass, "pack '" + name_ + "' has no pass '" + std::string(name) + "'");
  return it->second;
}

size_t PackReader::variant_count(std::string_view pass) const { return find_pass(pass).manifest->variants.size(); }

std::vector<std::vector<std::string>> PackReader::keyword_groups(std::string_view pass) const {
  return find_pass(pass).groups;
}

std::string_view PackReader::blob(uint32_t id) const {
  if (id >= blobs_.size()) throw PackError(PackError::Code::Format, "blob id " + std::to_string(id) + " out of range");
  const Blob& b = blobs_[id];
  std::string_view stored = std::string_view(archive_).substr(b.offset, b.stored_size);
  if (b.stored_size == b.raw_size) return stored;
  std::lock_guard lock(*decompress_mutex_);
  auto& slot = decompressed_[id];
  if (!slot) {
    auto raw = std::make_unique<std::string>(b.raw_size, '\0');
    size_t got = ZSTD_decompress(raw->data(), raw->size(), stored.data(), stored.size());
    if (ZSTD_isError(got) || got != b.raw_size)
      throw PackError(PackError::Code::Format, "blob " + std::to_string(id) + " does not decompress", archive_file_);
    if (XXH3_64bits(raw->data(), raw->size()) != b.hash)
      throw PackError(PackError::Code::Checksum, "blob " + std::to_string(id) + " fails its checksum", archive_file_);
    slot = std::move(raw);
  }
  return *slot;
}

SelectedVariant PackReader::variant(std::string_view pass_name, size_t index) const {
  const Pass& pass = find_pass(pass_name);
  const std::vector<ManifestVariant>& variants = pass.manifest->variants;
  if (index >= variants.size()) throw PackError(PackError::Code::Format, "variant index out of range");
  const ManifestVariant& v = variants[index];
  SelectedVariant selected;
  selected.pass = std::string(pass_name);
  selected.index = index;
  selected.keywords = v.keywords;
  for (const auto& [stage, binary_id] : v.binaries) {
    const ManifestBinary& binary = manifest_.binaries[binary_id];  // in range: check_indices
    StageView view;
    view.stage = std::string(stage_name(stage));
    view.entry_point = binary.entry;
    auto get = [&](Target target) -> std::string_view {
      auto it = binary.blobs.find(target);
      return it == binary.blobs.end() ? std::string_view{} : blob(it->second);
    };
    view.spirv = get(Target::Spirv);
    view.glsl = get(Target::Glsl);
    view.gles = get(Target::Gles);
    view.msl = get(Target::Msl);
    view.reflection = &manifest_.reflections[binary.reflection];
    selected.stages.push_back(view);
  }
  return selected;
}

SelectedVariant PackReader::select(std::string_view pass_name, const std::vector<std::string>& keywords, bool strict) const {
  const Pass& pass = find_pass(pass_name);
  std::vector<std::string> chosen;
  std::vector<bool> group_set(pass.groups.size(), false);
  std::set<std::string> requested(keywords.begin(), keywords.end());
  requested.erase("");
  for (const std::string& keyword : requested) {
    bool found = false;
    for (size_t g = 0; g < pass.groups.size() && !found; ++g) {
      if (std::find(pass.groups[g].begin(), pass.groups[g].end(), keyword) == pass.groups[g].end()) continue;
      found = true;
      if (group_set[g])
        throw PackError(PackError::Code::ConflictingKeywords,
                        "pass '" + std::string(pass_name) + "': keywords of one group requested together, including '" +
                            keyword + "'; a group takes at most one keyword");
      group_set[g] = true;
      chosen.push_back(keyword);
    }
    if (!found && strict)
      throw PackError(PackError::Code::UnknownKeyword,
                      "pass '" + std::string(pass_name) + "' does not declare keyword '" + keyword + "'");
  }
  for (size_t g = 0; g < pass.groups.size(); ++g) {
    if (group_set[g]) continue;
    if (std::find(pass.groups[g].begin(), pass.groups[g].end(), "") == pass.groups[g].end()) {
      if (pass.groups[g].size() == 1) {
        chosen.push_back(pass.groups[g][0]);  // a one-keyword multi_compile is always on
        continue;
      }
      throw PackError(PackError::Code::MissingKeyword, "pass '" + std::string(pass_name) + "' needs one of: " +
                                                           join(pass.groups[g]));
    }
  }
  std::sort(chosen.begin(), chosen.end());
  auto it = pass.by_key.find(join(chosen));
  if (it != pass.by_key.end()) return variant(pass_name, it->second);

  // Stripped: name the requested keywords that no variant of this pass has together with the rest.
  std::vector<std::string> missing;
  for (const std::string& keyword : chosen) {
    bool anywhere = false;
    for (const auto& [key, index] : pass.by_key) {
      const std::vector<std::string>& kw = pass.manifest->variants[index].keywords;
      if (std::find(kw.begin(), kw.end(), keyword) != kw.end()) anywhere = true;
    }
    if (!anywhere) missing.push_back(keyword);
  }
  // Nearest existing variants by symmetric difference, as hints only.
  std::vector<std::pair<size_t, std::string>> nearest;
  for (const auto& [key, index] : pass.by_key) {
    const std::vector<std::string>& kw = pass.manifest->variants[index].keywords;
    std::vector<std::string> diff;
    std::set_symmetric_difference(kw.begin(), kw.end(), chosen.begin(), chosen.end(), std::back_inserter(diff));
    nearest.emplace_back(diff.size(), key);
  }
  std::sort(nearest.begin(), nearest.end());
  std::string message = "pass '" + std::string(pass_name) + "' has no variant [" + join(chosen) +
                        "]: it was stripped from pack '" + name_ + "' (constraints, scene profiles or budget)";
  if (!missing.empty()) message += "; no variant at all has: " + join(missing);
  if (!nearest.empty()) {
    message += "; nearest variants in the pack:";
    for (size_t i = 0; i < nearest.size() && i < 3; ++i) message += " [" + nearest[i].second + "]";
  }
  throw PackError(PackError::Code::Stripped, message);
}

}  // namespace kiln
