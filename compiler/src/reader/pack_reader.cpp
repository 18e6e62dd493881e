// SPDX-License-Identifier: Apache-2.0
#include "kiln/pack_reader.hpp"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/inotify.h>
#include <sys/stat.h>
#include <unistd.h>
#include <xxhash.h>
#include <zstd.h>

#include <algorithm>
#include <atomic>
#include <mutex>
#include <cerrno>
#include <functional>
#include <map>
#include <fstream>
#include <cstdlib>
#include <new>
#include <cstring>
#include <optional>
#include <set>
#include <span>
#include <utility>

#include <nlohmann/json.hpp>

#include "kiln/bounded_json.hpp"
#include "kiln/manifest_json.hpp"
#include "kiln/pack_format.hpp"
#include "kiln/runtime_index.hpp"
#include "kiln/usage_log.hpp"

namespace kiln {
namespace {

using nlohmann::json;

// Which file a path names, as far as poll_update() needs to know: a build replaces a pack's files by rename, so a
// replaced file is another inode (the reader keeps the one it read mapped, so its number is not reused meanwhile).
struct FileIdentity {
  bool exists = false;
  uint64_t device = 0, inode = 0, size = 0;
  int64_t modified_seconds = 0, modified_nanoseconds = 0;
  static FileIdentity of(const struct stat& info) {
    return {true, static_cast<uint64_t>(info.st_dev), static_cast<uint64_t>(info.st_ino), static_cast<uint64_t>(info.st_size),
            static_cast<int64_t>(info.st_mtim.tv_sec), static_cast<int64_t>(info.st_mtim.tv_nsec)};
  }
  static FileIdentity at(const std::string& path) {
    struct stat info {};
    return ::stat(path.c_str(), &info) == 0 ? of(info) : FileIdentity{};
  }
  bool operator==(const FileIdentity&) const = default;
};

// A pack file, mapped read-only: a regular file only (a FIFO would block, a device never end), checked before it
// is opened and again on the opened descriptor (opened without blocking, so a file swapped for a FIFO in between
// cannot block either); its size checked against `expected` (the manifest's record) and `limit` before it is
// mapped. `what` names the file in messages ("the manifest"). `check_header`, if given, sees the file's first
// `header_size` bytes (fewer if the file is shorter), read before the file is mapped.
class MappedFile {
 public:
  MappedFile() = default;
  MappedFile(const std::string& path, const std::string& what, uint64_t limit, std::optional<uint64_t> expected = std::nullopt,
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
    identity_ = FileIdentity::of(info);
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
    if (check_header) {
      std::string header(static_cast<size_t>(std::min<uint64_t>(size, header_size)), '\0');
      size_t got = 0;
      while (got < header.size()) {
        const ssize_t n = ::pread(fd, header.data() + got, header.size() - got, static_cast<off_t>(got));
        if (n < 0 && errno == EINTR) continue;
        if (n < 0) throw system_error("cannot read the file");
        if (n == 0) break;
        got += static_cast<size_t>(n);
      }
      header.resize(got);
      check_header(header);
    }
    if (size == 0) return;
    void* at = ::mmap(nullptr, size, PROT_READ, MAP_PRIVATE, fd, 0);
    if (at == MAP_FAILED) {
      if (errno == ENOMEM) throw std::bad_alloc();
      throw system_error("cannot map the file");
    }
    data_ = static_cast<const char*>(at);
    size_ = size;
  }
  MappedFile(MappedFile&& other) noexcept
      : data_(std::exchange(other.data_, nullptr)), size_(std::exchange(other.size_, 0)), identity_(other.identity_) {}
  MappedFile& operator=(MappedFile&& other) noexcept {
    std::swap(data_, other.data_);
    std::swap(size_, other.size_);
    std::swap(identity_, other.identity_);
    return *this;
  }
  ~MappedFile() {
    if (data_) ::munmap(const_cast<char*>(data_), size_);
  }
  std::string_view bytes() const { return {data_, size_}; }
  // The file that was opened (not whatever the path names now).
  const FileIdentity& identity() const { return identity_; }

 private:
  const char* data_ = nullptr;
  size_t size_ = 0;
  FileIdentity identity_;
};

uint64_t get64(std::string_view bytes, size_t at) {
  uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v |= static_cast<uint64_t>(static_cast<unsigned char>(bytes[at + i])) << (8 * i);
  return v;
}

uint32_t get32(std::string_view bytes, size_t at) {
  uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v |= static_cast<uint32_t>(static_cast<unsigned char>(bytes[at + i])) << (8 * i);
  return v;
}

std::string hex64(uint64_t value) {
  char text[17];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(value));
  return text;
}

// "file:line:col" of a byte offset in `text` (both 1-based).
std::string location_of(const std::filesystem::path& file, std::string_view text, size_t offset) {
  offset = std::min(offset, text.size());
  size_t line = 1 + static_cast<size_t>(std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(offset), '\n'));
  size_t line_start = text.rfind('\n', offset == 0 ? std::string_view::npos : offset - 1);
  size_t column = offset - (line_start == std::string_view::npos ? 0 : line_start + 1) + 1;
  return file.string() + ":" + std::to_string(line) + ":" + std::to_string(column);
}

template <class Words>
std::string join(const Words& words) {
  std::string out;
  for (const auto& w : words) {
    if (!out.empty()) out += ' ';
    out += w;
  }
  return out.empty() ? "<none>" : out;
}

// Where `pattern` first occurs in `text` at or after `from` (npos if nowhere): glibc's memmem, several times faster
// than std::string_view::find on text with a newline every few dozen bytes.
size_t find(std::string_view text, std::string_view pattern, size_t from = 0) {
  if (from >= text.size()) return std::string_view::npos;  // also an empty file's view, whose data() is null
  const void* at = ::memmem(text.data() + from, text.size() - from, pattern.data(), pattern.size());
  return at ? static_cast<size_t>(static_cast<const char*>(at) - text.data()) : std::string_view::npos;
}

std::string version_message(const std::string& what) {
  return what + " (this reader reads version " + std::to_string(kPackFormatVersion) +
         "): rebuild the pack with this version of kiln";
}

// The manifest's own checksum (pack_format.hpp): found in the text, checked against the text with its digits taken
// as zeros. It runs before anything in the text is used, so a damaged or foreign manifest costs one hash of its
// bytes, never a parse.
void check_manifest_checksum(std::string_view text, const std::string& manifest_name) {
  // The top-level field, as kiln writes it (one space of indentation; see scan_manifest_head): one search that stops
  // half-way through the file, where the keys' order puts it.
  const size_t field = find(text, "\n " + std::string(kManifestChecksumField));
  const size_t digits = field + 2 + std::strlen(kManifestChecksumField);
  if (field == std::string_view::npos || text.size() < digits + kManifestChecksumDigits)
    throw PackError(PackError::Code::Format, "not a kiln pack manifest: it has no checksum (\"manifest_xxh3_64\")",
                    manifest_name);
  XXH3_state_t* state = XXH3_createState();
  if (!state) throw std::bad_alloc();
  XXH3_64bits_reset(state);
  XXH3_64bits_update(state, text.data(), digits);
  XXH3_64bits_update(state, std::string(kManifestChecksumDigits, '0').data(), kManifestChecksumDigits);
  XXH3_64bits_update(state, text.data() + digits + kManifestChecksumDigits, text.size() - digits - kManifestChecksumDigits);
  const std::string computed = hex64(XXH3_64bits_digest(state));
  XXH3_freeState(state);
  if (text.substr(digits, kManifestChecksumDigits) != computed)
    throw PackError(PackError::Code::Checksum, "the manifest fails its checksum (changed since kiln wrote it)",
                    manifest_name);
}

// What the reader needs from the manifest: its name and its record of the archive.
struct ManifestHead {
  std::string name;
  ManifestArchive archive;
};

// The head of a manifest whose checksum holds, without parsing the rest: kiln writes the manifest with one space of
// indentation per level (pack_writer.cpp), so "\n \"key\": " is a top-level key and nothing else (a string holds no
// raw newline), and a top-level value ends at ",\n" or, for an object, at "\n }". Each value found is parsed alone.
ManifestHead scan_manifest_head(std::string_view text, const std::string& manifest_name) {
  // The keys are written in order (archive, ..., format, format_version, ..., name, ...): each search starts where
  // the previous key was found, so the head costs one pass over the first half of the file.
  size_t from = 0;
  auto value_of = [&](std::string_view key, bool object) -> std::optional<std::string_view> {
    const std::string pattern = "\n \"" + std::string(key) + "\": ";
    const size_t at = find(text, pattern, from);
    if (at == std::string_view::npos) return std::nullopt;
    from = at;
    const size_t start = at + pattern.size();
    const size_t end = object ? find(text, "\n }", start) : text.find_first_of(",\n", start);
    if (end == std::string_view::npos) return std::nullopt;
    return text.substr(start, end - start + (object ? 3 : 0));
  };
  auto parsed = [&](std::optional<std::string_view> value) {
    try {
      return value ? parse_json_bounded(*value, {kMaxManifestBytes, kMaxJsonDepth}) : json();
    } catch (const JsonDecodeError&) {
      return json();
    }
  };
  auto malformed = [&](const std::string& what) { return PackError(PackError::Code::Format, "malformed manifest: " + what, manifest_name); };
  const std::optional<std::string_view> archive_text = value_of("archive", true);
  if (parsed(value_of("format", false)) != kManifestFormat)
    throw PackError(PackError::Code::Format, "not a kiln pack manifest (no \"format\": \"" + std::string(kManifestFormat) + "\")",
                    manifest_name);
  const std::optional<std::string_view> version = value_of("format_version", false);
  if (!version) throw PackError(PackError::Code::Version, version_message("the manifest has no format_version"), manifest_name);
  if (*version != std::to_string(kPackFormatVersion))
    throw PackError(PackError::Code::Version, version_message("pack format version " + std::string(*version) + " is not supported"),
                    manifest_name);
  ManifestHead head;
  const json name = parsed(value_of("name", false));
  if (!name.is_string()) throw malformed("top level: has no \"name\"");
  head.name = name.get<std::string>();
  try {
    const json archive = parsed(archive_text);
    if (archive.is_null()) throw malformed("top level: has no \"archive\"");
    head.archive = archive.get<ManifestArchive>();
  } catch (const ManifestError& error) {
    throw malformed(error.inside("/archive").what());
  }
  return head;
}

// A game's open parses only the manifest's head, but the groups' pragmas decide which keywords fold and where their
// values go (kiln/folded_keywords.hpp): the index's must be the manifest's, or a pack whose index folds keywords its
// JSON does not would be refused by tools (the whole index is compared there) and used by games. Under "passes" kiln
// writes each group's "pragma" on a line of its own (one space of indentation per level), and no other key of that
// name: one pass over the passes' text finds them in the index's order.
void check_group_pragmas(std::string_view text, const runtime::Index& index, const std::string& manifest_name) {
  auto refuse = [&](const std::string& what) {
    return PackError(PackError::Code::Format,
                     "malformed manifest: its keyword groups are not the runtime index's: " + what, manifest_name);
  };
  constexpr std::string_view kPasses = "\n \"passes\": [", kKey = "\"pragma\": ";
  size_t from = find(text, kPasses);
  if (from == std::string_view::npos) throw refuse("it has no \"passes\"");
  from += kPasses.size();
  const size_t end = text.substr(from, 1) == "]" ? from : find(text, "\n ]", from);
  if (end == std::string_view::npos) throw refuse("its \"passes\" do not end");
  const std::string_view passes = text.substr(0, end);
  size_t group = 0;
  for (size_t at = find(passes, kKey, from); at != std::string_view::npos; at = find(passes, kKey, from)) {
    from = at + kKey.size();
    size_t line = at;
    while (line > 0 && passes[line - 1] == ' ') --line;
    if (line == 0 || passes[line - 1] != '\n') continue;  // not a key: inside a string or after another field
    const std::string_view value = passes.substr(from, passes.find_first_of(",\n", from) - from);
    json pragma;
    try {
      pragma = parse_json_bounded(value, {value.size(), kMaxJsonDepth});
    } catch (const JsonDecodeError&) {
    }
    if (!pragma.is_string()) throw refuse("group " + std::to_string(group) + "'s pragma is not a string");
    if (group >= index.groups.size())
      throw refuse("the manifest has more groups than the index's " + std::to_string(index.groups.size()));
    if (pragma.get<std::string>() != index.groups[group].pragma)
      throw refuse("group " + std::to_string(group) + " is '" + echoed(pragma.get<std::string>()) + "' in the manifest, '" +
                   echoed(index.groups[group].pragma) + "' in the index");
    ++group;
  }
  if (group != index.groups.size())
    throw refuse("the manifest has " + std::to_string(group) + " groups, the index " + std::to_string(index.groups.size()));
}

// The whole manifest, parsed and typed (a tool's open, or manifest() after a game's).
Manifest parse_manifest(std::string_view text, const std::filesystem::path& manifest_file) {
  const std::string manifest_name = manifest_file.string();
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
                    version_message(format_version.is_null()        ? std::string("the manifest has no format_version")
                                    : format_version.is_primitive() ? "pack format version " + format_version.dump() + " is not supported"
                                                                    : std::string("the manifest's format_version is not a number")),
                    manifest_name);
  try {
    Manifest manifest = m.get<Manifest>();
    manifest.check_indices();
    return manifest;
  } catch (const ManifestError& error) {
    throw PackError(PackError::Code::Format, std::string("malformed manifest: ") + error.what(), manifest_name);
  }
}

struct Blob {
  uint64_t offset = 0;
  uint64_t stored_size = 0;
  uint64_t raw_size = 0;
  uint64_t hash = 0;  // XXH3-64 of the raw bytes
};

// One pass's selection table: every variant's keyword ids hashed, sorted by hash.
struct PassKeys {
  std::vector<std::pair<uint64_t, uint32_t>> by_hash;  // hash of the keyword ids -> variant index in the pass
};

uint64_t hash_ids(const uint32_t* ids, size_t count) { return XXH3_64bits(ids, count * sizeof(uint32_t)); }

// A compressed blob's bytes, checked: its frame's sizes before its buffer is made (so the buffer is only as large as
// the frame can fill), its checksum after.
std::string decompress_checked(const Blob& b, std::string_view stored, const std::string& which, const std::string& file) {
  auto format = [&](const std::string& what) { return PackError(PackError::Code::Format, which + what, file); };
  const size_t frame_size = ZSTD_findFrameCompressedSize(stored.data(), stored.size());
  if (ZSTD_isError(frame_size) || frame_size != stored.size()) throw format(" is not one zstd frame");
  const unsigned long long content_size = ZSTD_getFrameContentSize(stored.data(), stored.size());
  if (content_size == ZSTD_CONTENTSIZE_UNKNOWN || content_size == ZSTD_CONTENTSIZE_ERROR)
    throw format(": its zstd frame does not record its size");
  if (content_size != b.raw_size)
    throw format(": its zstd frame holds " + std::to_string(content_size) + " bytes, the blob table records " +
                 std::to_string(b.raw_size));
  // A frame's header may claim any size; no frame fills more than one 128 KiB block per 4 of its bytes (a 3-byte
  // block header and 1 byte repeated), so a larger claim is refused before it is allocated.
  if (b.raw_size / ZSTD_BLOCKSIZE_MAX > b.stored_size / 4)
    throw format(": a zstd frame of " + std::to_string(b.stored_size) + " bytes cannot hold " + std::to_string(b.raw_size));
  std::string raw(b.raw_size, '\0');
  const size_t got = ZSTD_decompress(raw.data(), raw.size(), stored.data(), stored.size());
  if (ZSTD_isError(got) || got != b.raw_size)
    throw PackError(PackError::Code::Checksum, which + " is damaged: its zstd frame does not decompress", file);
  if (XXH3_64bits(raw.data(), raw.size()) != b.hash) throw PackError(PackError::Code::Checksum, which + " fails its checksum", file);
  return raw;
}

// This thread's stripe of a striped counter: threads take them in turn, the 17th shares the first's.
constexpr uint32_t kStripes = 16;
uint32_t thread_stripe() noexcept {
  static std::atomic<uint32_t> next{0};
  thread_local const uint32_t mine = next.fetch_add(1, std::memory_order_relaxed) % kStripes;
  return mine;
}

// The selections one pack version served, per pass and variant (the hot path: one relaxed increment). Striped: each
// thread adds to its own stripe (kStripes of them, each starting on its own cache line), so threads that select the
// same variant at once do not pass one cache line between their cores; the log adds the stripes. 8 bytes per variant
// and stripe: 128 per variant.
struct PassCounts {
  uint32_t stride = 0;                             // counters per stripe: the variant count rounded up to 8
  std::unique_ptr<std::atomic<uint64_t>[]> storage;
  std::atomic<uint64_t>* counts = nullptr;         // stripe s, variant v: counts[s * stride + v]; 64-byte aligned
  explicit PassCounts(uint32_t variants) : stride((variants + 7) / 8 * 8) {
    const size_t n = size_t(stride) * kStripes + 8;
    storage = std::make_unique<std::atomic<uint64_t>[]>(n);
    for (size_t i = 0; i < n; ++i) storage[i].store(0, std::memory_order_relaxed);
    const auto address = reinterpret_cast<uintptr_t>(storage.get());
    counts = storage.get() + ((64 - address % 64) % 64) / sizeof(std::atomic<uint64_t>);
  }
  uint64_t total(uint32_t variant) const {
    uint64_t sum = 0;
    for (uint32_t s = 0; s < kStripes; ++s) sum += counts[size_t(s) * stride + variant].load(std::memory_order_relaxed);
    return sum;
  }
};
using ServedCounts = std::vector<PassCounts>;  // per pass of the version

// What record_usage() keeps over the reader's life, across pack switches: keyed by pass name and keyword set, so a
// selection counts the same whichever pack version served it. The served counts of versions no longer kept are
// folded into `carried`; the keyword sets the pack lacks (Stripped) are kept with their nearest variant (rare).
struct UsageRecorder {
  struct Missing {
    uint64_t count = 0;
    std::vector<std::string> nearest;
  };
  using Key = std::pair<std::string, std::vector<std::string>>;  // pass, keywords
  mutable std::mutex mutex;
  PackReader::UsageOptions options;  // under the mutex
  std::map<Key, Missing> missing;
  std::map<Key, uint64_t> carried;
  uint64_t missing_dropped = 0;
};

// Readers of the pack version served now (select() and every other call) pin it; poll_update() frees a version it
// replaced only once no call that may have seen it is still running. Epoch-based: a call counts itself, on its
// thread's stripe, under the parity of the epoch it saw (one atomic increment on a cache line of its own, no lock);
// the poller advances the epoch only when no call of the epoch before is still counted, so a version replaced in
// epoch E is unseen by every running call once the epoch reaches E + 2.
class ReaderEpochs {
 public:
  uint32_t enter(uint32_t stripe) noexcept {
    for (;;) {
      const uint64_t epoch = epoch_.load(std::memory_order_seq_cst);
      stripes_[stripe].active[epoch & 1].fetch_add(1, std::memory_order_seq_cst);
      if (epoch_.load(std::memory_order_seq_cst) == epoch) return static_cast<uint32_t>(epoch & 1);
      stripes_[stripe].active[epoch & 1].fetch_sub(1, std::memory_order_release);  // the epoch moved: count again
    }
  }
  void leave(uint32_t stripe, uint32_t parity) noexcept { stripes_[stripe].active[parity].fetch_sub(1, std::memory_order_release); }
  uint64_t epoch() const noexcept { return epoch_.load(std::memory_order_seq_cst); }
  // One poller at a time.
  bool try_advance() noexcept {
    const uint64_t epoch = epoch_.load(std::memory_order_seq_cst);
    for (const Stripe& stripe : stripes_)
      if (stripe.active[(epoch + 1) & 1].load(std::memory_order_seq_cst) != 0) return false;
    epoch_.store(epoch + 1, std::memory_order_seq_cst);
    return true;
  }

 private:
  struct alignas(64) Stripe {
    std::atomic<uint64_t> active[2] = {0, 0};
  };
  std::atomic<uint64_t> epoch_{0};
  Stripe stripes_[kStripes];
};

// The version a call uses, pinned for the call's length.
template <class State>
class Pinned {
 public:
  Pinned(ReaderEpochs& epochs, const std::atomic<State*>& current) noexcept
      : epochs_(epochs), stripe_(thread_stripe()), parity_(epochs.enter(stripe_)), state_(current.load(std::memory_order_seq_cst)) {}
  ~Pinned() { epochs_.leave(stripe_, parity_); }
  Pinned(const Pinned&) = delete;
  Pinned& operator=(const Pinned&) = delete;
  State& operator*() const noexcept { return *state_; }

 private:
  ReaderEpochs& epochs_;
  uint32_t stripe_, parity_;
  State* state_;
};

}  // namespace

// One pack version.
struct PackReader::State {
  std::string name;
  std::filesystem::path manifest_file;
  std::string archive_file;  // its path, for errors found when a blob is first used
  MappedFile manifest_text, archive;
  std::vector<Blob> blobs;
  runtime::Index index;
  std::vector<PassKeys> keys;  // per pass
  // Blobs stored as they are: checked on first use (1 when checked). Compressed ones: decompressed (and checked)
  // on first use and kept. The reader may be shared between threads.
  std::unique_ptr<std::atomic<uint8_t>[]> checked;
  std::mutex mutex;
  std::unique_ptr<std::atomic<const std::string*>[]> decompressed;  // per blob, once decompressed
  std::vector<std::unique_ptr<std::string>> owned;                   // what `decompressed` points at (under the mutex)
  std::unique_ptr<std::atomic<const Reflection*>[]> reflections;
  std::vector<std::unique_ptr<Reflection>> decoded;  // owns what `reflections` points at (under the mutex)
  std::once_flag manifest_once;
  std::optional<Manifest> manifest;
  // Usage recording: made (under Live::mutex) when recording starts or the version is switched to while recording.
  std::unique_ptr<ServedCounts> counts;
  std::atomic<ServedCounts*> served{nullptr};
  std::vector<uint64_t> identities;  // per variant of the index, binary identity; made by poll_update (under its mutex)
};

struct PackReader::Live {
  ~Live() {
    if (usage) static_cast<void>(flush_usage_log());  // errors are the caller's to see through flush_usage()
    if (inotify >= 0) ::close(inotify);
  }
  PackResult<size_t> flush_usage_log() const noexcept;  // under `mutex`, or from the destructor
  void reclaim();                                       // under `mutex`
  void count_served(const State& state, uint32_t pass, uint32_t variant) const noexcept {
    ServedCounts* counts = state.served.load(std::memory_order_acquire);
    if (counts && pass < counts->size() && variant < state.index.passes[pass].variant_count)
      (*counts)[pass].counts[size_t(thread_stripe()) * (*counts)[pass].stride + variant].fetch_add(1, std::memory_order_relaxed);
  }

  ReaderEpochs epochs;
  std::atomic<State*> current{nullptr};
  std::unique_ptr<State> current_owner;
  struct Retired {
    std::unique_ptr<State> state;
    uint64_t epoch = 0, poll = 0;  // when it was replaced
  };
  std::vector<Retired> retired;
  mutable std::mutex mutex;  // poll_update, record_usage, flush_usage, update_fd
  std::filesystem::path manifest_file;
  uint64_t polls = 0, version = 1;
  FileIdentity seen;  // the manifest file that holds the version served now
  // The last new pack refused, reported once: its manifest and the archive it named.
  bool refused = false;
  FileIdentity refused_manifest, refused_archive;
  std::string refused_archive_file;
  std::unique_ptr<UsageRecorder> usage;            // made by the first record_usage()
  std::atomic<UsageRecorder*> recording{nullptr};  // `usage` once recording
  int inotify = -1;
};

PackReader::PackReader() : live_(std::make_unique<Live>()) {}
PackReader::PackReader(PackReader&&) noexcept = default;
PackReader& PackReader::operator=(PackReader&&) noexcept = default;
PackReader::~PackReader() = default;

const StageView* SelectedVariant::stage(std::string_view name) const {
  for (const StageView& s : stages)
    if (s.stage == name) return &s;
  return nullptr;
}

PackReader PackReader::open(const std::filesystem::path& path, Check check) {
  try {
    return open_checked(path, check);
  } catch (const std::bad_alloc&) {
    throw PackError(PackError::Code::OutOfMemory, "the pack does not fit in the memory this process may use", path.string());
  }
}

PackReader PackReader::open_checked(const std::filesystem::path& path, Check check) {
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
  std::unique_ptr<State> version = load(manifest_file, check);
  reader.name_ = version->name;
  Live& live = *reader.live_;
  live.manifest_file = manifest_file;
  live.seen = version->manifest_text.identity();
  live.current.store(version.get(), std::memory_order_seq_cst);
  live.current_owner = std::move(version);
  return reader;
}

// One pack version from its manifest file: what open() checks, in its order. `archive_file`, when given, is set to
// the archive's path as soon as the manifest names it (poll_update() keeps it with a refusal).
std::unique_ptr<PackReader::State> PackReader::load(const std::filesystem::path& manifest_file, Check check,
                                                    std::string* archive_path) {
  auto owner = std::make_unique<State>();
  State& state = *owner;
  state.manifest_file = manifest_file;
  const std::string manifest_name = manifest_file.string();
  state.manifest_text = MappedFile(manifest_name, "the manifest", kMaxManifestBytes);
  const std::string_view text = state.manifest_text.bytes();
  // Sizes, then the checksum, then the parse: what is parsed is what kiln wrote, bounded in depth.
  check_manifest_checksum(text, manifest_name);
  ManifestHead head;
  if (check == Check::Full) {
    state.manifest = parse_manifest(text, manifest_file);
    head = {state.manifest->name, state.manifest->archive};
  } else {
    head = scan_manifest_head(text, manifest_name);
  }
  auto malformed = [&](const std::string& what) {
    return PackError(PackError::Code::Format, "malformed manifest: " + what, manifest_name);
  };
  state.name = head.name;
  // The manifest names the archive; a name of any other shape ("../x", "/etc/passwd") is refused before any
  // file is opened, so a hostile manifest can make the reader read nothing but this pack's own archive.
  if (std::string problem = name_problem(state.name); !problem.empty())
    throw malformed("/name: \"" + echoed(state.name) + "\" is not a pack name: it " + problem);
  const std::string& archive_name = head.archive.file;
  if (archive_name != archive_file_name(state.name, head.archive.xxh3_64) || !is_archive_file_name(archive_name, state.name))
    throw malformed("/archive/file: " + json(archive_name).dump() + " is not the archive's name, <name>.<xxh3_64>" +
                    std::string(kArchiveExtension));
  state.archive_file = (manifest_file.parent_path() / archive_name).string();
  if (archive_path) *archive_path = state.archive_file;
  auto fail = [&](PackError::Code code, const std::string& message) { throw PackError(code, message, state.archive_file); };
  const std::string archive_what = "archive of pack '" + state.name + "'";
  // The header (magic, version, size) is read and checked before the archive is mapped.
  auto check_header = [&](std::string_view header) {
    if (header.size() < kPackHeaderSize || std::memcmp(header.data(), kPackMagic, 8) != 0)
      fail(PackError::Code::Format, archive_what + " has no KILNPACK header");
    const uint32_t version = get32(header, 8);
    if (version != kPackFormatVersion)
      fail(PackError::Code::Version, version_message("archive format version " + std::to_string(version) + " is not supported"));
    if (get64(header, 24) != head.archive.size)
      fail(PackError::Code::Checksum, archive_what + " is truncated or has the wrong size");
  };
  state.archive = MappedFile(state.archive_file, archive_what, kMaxArchiveBytes, head.archive.size, check_header, kPackHeaderSize);
  const std::string_view bytes = state.archive.bytes();
  if (check == Check::Full && (XXH3_64bits(bytes.data() + kPackHeaderSize, bytes.size() - kPackHeaderSize) != get64(bytes, 16) ||
                               hex64(XXH3_64bits(bytes.data(), bytes.size())) != head.archive.xxh3_64))
    fail(PackError::Code::Checksum, archive_what + " fails its checksum");
  // The head: the blob table and the index, checked together before either is read.
  const uint32_t count = get32(bytes, 12);
  const uint64_t index_offset = get64(bytes, 32), index_size = get64(bytes, 40);
  if (index_offset != kPackHeaderSize + kPackBlobEntrySize * uint64_t{count} || index_offset > bytes.size() ||
      index_size > bytes.size() - index_offset)
    fail(PackError::Code::Format, "archive blob table or runtime index is out of bounds");
  if (XXH3_64bits(bytes.data() + kPackHeaderSize, index_offset + index_size - kPackHeaderSize) != get64(bytes, 48))
    fail(PackError::Code::Checksum, archive_what + ": its blob table or runtime index fails its checksum");
  if (count != head.archive.blobs)
    throw malformed("/archive/blobs: " + std::to_string(head.archive.blobs) + " blobs, the archive holds " + std::to_string(count));
  state.blobs.reserve(count);
  for (uint32_t i = 0; i < count; ++i) {
    const size_t at = kPackHeaderSize + kPackBlobEntrySize * i;
    Blob blob{get64(bytes, at), get64(bytes, at + 8), get64(bytes, at + 16), get64(bytes, at + 24)};
    auto which = [&] { return "blob " + std::to_string(i); };
    if (blob.offset < index_offset + index_size || blob.offset > bytes.size() || blob.stored_size > bytes.size() - blob.offset)
      fail(PackError::Code::Format, which() + " is out of bounds");
    if (blob.raw_size > kMaxBlobBytes)
      fail(PackError::Code::Format, which() + ": raw size " + std::to_string(blob.raw_size) +
                                        " is over the pack format's limit of " + std::to_string(kMaxBlobBytes) + " bytes");
    if (blob.stored_size > blob.raw_size)
      fail(PackError::Code::Format, which() + ": stored size " + std::to_string(blob.stored_size) +
                                        " is larger than its raw size " + std::to_string(blob.raw_size));
    state.blobs.push_back(blob);
  }
  try {
    state.index = runtime::Index::decode(bytes.substr(index_offset, index_size), count);
  } catch (const runtime::IndexError& error) {
    fail(PackError::Code::Format, archive_what + ": " + error.what());
  }
  if (check == Check::OnUse) check_group_pragmas(text, state.index, manifest_name);  // Full compares the whole index
  state.checked = std::make_unique<std::atomic<uint8_t>[]>(count);
  state.decompressed = std::make_unique<std::atomic<const std::string*>[]>(count);
  state.reflections = std::make_unique<std::atomic<const Reflection*>[]>(state.index.reflections.size());
  state.decoded.resize(state.index.reflections.size());
  if (check == Check::Full) {
    for (uint32_t i = 0; i < count; ++i) {
      const Blob& b = state.blobs[i];
      if (b.stored_size == b.raw_size) blob_of(state, i);
      else decompress_checked(b, bytes.substr(b.offset, b.stored_size), "blob " + std::to_string(i), state.archive_file);
    }
    if (runtime::encode(*state.manifest) != bytes.substr(index_offset, index_size))
      fail(PackError::Code::Format, archive_what + ": its runtime index does not match the manifest");
  }
  // Selection by keyword ids: each variant's sorted ids, hashed.
  const runtime::Index& index = state.index;
  state.keys.resize(index.passes.size());
  for (size_t p = 0; p < index.passes.size(); ++p) {
    const runtime::Pass& pass = index.passes[p];
    auto& by_hash = state.keys[p].by_hash;
    by_hash.reserve(pass.variant_count);
    for (uint32_t v = 0; v < pass.variant_count; ++v) {
      const runtime::Variant& variant = index.variants[pass.first_variant + v];
      by_hash.emplace_back(hash_ids(index.variant_keywords.data() + variant.first_keyword, variant.keyword_count), v);
    }
    std::sort(by_hash.begin(), by_hash.end());
  }
  return owner;
}

const Manifest& PackReader::manifest() const {
  Pinned<State> pinned(live_->epochs, live_->current);
  State& state = *pinned;
  std::call_once(state.manifest_once, [&] {
    if (state.manifest) return;
    try {
      state.manifest = parse_manifest(state.manifest_text.bytes(), state.manifest_file);
    } catch (const std::bad_alloc&) {
      throw PackError(PackError::Code::OutOfMemory, "the manifest does not fit in the memory this process may use",
                      state.manifest_file.string());
    }
  });
  return *state.manifest;
}

const runtime::Index& PackReader::index() const {
  Pinned<State> pinned(live_->epochs, live_->current);
  return (*pinned).index;
}

namespace {

// The served counters of a pack version, zero.
std::unique_ptr<ServedCounts> counts_for(const runtime::Index& index) {
  auto counts = std::make_unique<ServedCounts>();
  counts->reserve(index.passes.size());
  for (const runtime::Pass& pass : index.passes) counts->emplace_back(pass.variant_count);
  return counts;
}

// Calls `each(pass name, keywords, count)` for every variant a version's counters say was served.
template <class Each>
void for_each_served(const runtime::Index& ix, const ServedCounts& counts, Each&& each) {
  for (uint32_t p = 0; p < ix.passes.size() && p < counts.size(); ++p) {
    const runtime::Pass& pass = ix.passes[p];
    for (uint32_t v = 0; v < pass.variant_count; ++v) {
      const uint64_t count = counts[p].total(v);
      if (count == 0) continue;
      const runtime::Variant& variant = ix.variants[pass.first_variant + v];
      std::vector<std::string> keywords;
      for (uint32_t k = 0; k < variant.keyword_count; ++k)
        keywords.emplace_back(ix.keywords[ix.variant_keywords[variant.first_keyword + k]]);
      each(std::string(pass.name), std::move(keywords), count);
    }
  }
}

}  // namespace

void PackReader::record_usage(UsageOptions options) {
  Live& live = *live_;
  std::lock_guard lock(live.mutex);
  if (!live.usage) live.usage = std::make_unique<UsageRecorder>();
  {
    std::lock_guard usage_lock(live.usage->mutex);
    live.usage->options = std::move(options);
  }
  State& state = *live.current_owner;  // under the mutex: the version served now
  if (!state.counts) {
    state.counts = counts_for(state.index);
    state.served.store(state.counts.get(), std::memory_order_release);
  }
  live.recording.store(live.usage.get(), std::memory_order_release);
}

void PackReader::note_selected(uint32_t pass, uint32_t variant) const noexcept {
  if (!live_->recording.load(std::memory_order_acquire)) return;
  Pinned<State> pinned(live_->epochs, live_->current);
  live_->count_served(*pinned, pass, variant);
}

PackResult<size_t> PackReader::flush_usage() const noexcept {
  std::lock_guard lock(live_->mutex);
  return live_->flush_usage_log();
}

// Frees the versions poll_update() replaced once that is safe: after a later poll_update() call than the one that
// replaced them (the caller's views into them live until then) and once no call that may have seen them runs. Their
// served counts are folded into the recorder's first: nothing can add to them any more.
void PackReader::Live::reclaim() {
  for (int step = 0; step < 2 && !retired.empty(); ++step)
    if (!epochs.try_advance()) break;
  const uint64_t epoch = epochs.epoch();
  for (auto it = retired.begin(); it != retired.end();) {
    if (it->poll >= polls || epoch < it->epoch + 2) {
      ++it;
      continue;
    }
    if (usage && it->state->counts) {
      std::lock_guard lock(usage->mutex);
      for_each_served(it->state->index, *it->state->counts, [&](std::string pass, std::vector<std::string> keywords, uint64_t count) {
        usage->carried[{std::move(pass), std::move(keywords)}] += count;
      });
    }
    it = retired.erase(it);
  }
}

// The log (docs/usage.md, variants/schema/usage.schema.json): the pack's name, the game's tags, and per pass the
// keyword sets served and those missing, each with its count; sorted, so equal counts give equal bytes. Written to
// a file beside the target, then renamed over it: a reader of the log never sees half of it. Counts of every pack
// version served are added by pass name and keyword set; passes in the order of the pack served now, then those only
// earlier versions had, by name.
PackResult<size_t> PackReader::Live::flush_usage_log() const noexcept {
  const UsageRecorder* recorder = recording.load(std::memory_order_acquire);
  if (!recorder) return size_t{0};
  std::filesystem::path file;
  try {
    const State& state = *current_owner;
    std::map<std::string, std::string> tags;
    std::map<std::string, std::map<std::vector<std::string>, uint64_t>> served;
    std::map<std::string, std::vector<usage_log::Request>> missing_by_pass;
    size_t sets = 0;
    uint64_t dropped = 0;
    auto add = [&](std::string pass, std::vector<std::string> keywords, uint64_t count) {
      served[std::move(pass)][std::move(keywords)] += count;
    };
    {
      std::lock_guard lock(recorder->mutex);
      file = recorder->options.file;
      for (const auto& [key, value] : recorder->options.tags) tags[key] = value;
      for (const auto& [key, entry] : recorder->missing)
        missing_by_pass[key.first].push_back({key.second, entry.count, entry.nearest});
      for (const auto& [key, count] : recorder->carried) served[key.first][key.second] += count;
      dropped = recorder->missing_dropped;
    }
    if (file.empty()) return PackResult<size_t>(PackError::Code::Io, "no usage log file was given", "");
    for (const Retired& old : retired)
      if (old.state->counts) for_each_served(old.state->index, *old.state->counts, add);
    if (state.counts) for_each_served(state.index, *state.counts, add);
    std::vector<std::string> order;
    for (const runtime::Pass& pass : state.index.passes) order.emplace_back(pass.name);
    std::set<std::string> listed(order.begin(), order.end());
    for (const auto& [pass, counts] : served)
      if (listed.insert(pass).second) order.push_back(pass);
    for (const auto& [pass, requests] : missing_by_pass)
      if (listed.insert(pass).second) order.push_back(pass);
    std::vector<usage_log::Pass> passes;
    for (const std::string& name : order) {
      usage_log::Pass entry{name, {}, {}};
      if (auto it = served.find(name); it != served.end())
        for (const auto& [keywords, count] : it->second) entry.served.push_back({keywords, count, {}});
      if (auto missing = missing_by_pass.find(name); missing != missing_by_pass.end()) entry.missing = std::move(missing->second);
      if (entry.served.empty() && entry.missing.empty()) continue;
      sets += entry.served.size() + entry.missing.size();
      passes.push_back(std::move(entry));
    }
    const Result<void> written = usage_log::write_atomically(file, usage_log::text(state.name, tags, std::move(passes), dropped));
    if (!written) return PackResult<size_t>(PackError::Code::Io, written.error().message, file.string());
    return sets;
  } catch (const std::bad_alloc&) {
    return PackResult<size_t>(PackError::Code::OutOfMemory, "out of memory writing the usage log", file.string());
  } catch (const std::exception& error) {
    return PackResult<size_t>(PackError::Code::Io, std::string("cannot write the usage log: ") + error.what(), file.string());
  }
}

std::vector<std::string> PackReader::passes() const {
  Pinned<State> pinned(live_->epochs, live_->current);
  std::vector<std::string> names;
  for (const runtime::Pass& pass : (*pinned).index.passes) names.emplace_back(pass.name);
  return names;
}

uint32_t PackReader::find_pass(const State& state, std::string_view name) const {
  const std::vector<runtime::Pass>& passes = state.index.passes;
  for (size_t p = 0; p < passes.size(); ++p)
    if (passes[p].name == name) return static_cast<uint32_t>(p);
  throw PackError(PackError::Code::UnknownPass, "pack '" + name_ + "' has no pass '" + std::string(name) + "'");
}

size_t PackReader::variant_count(std::string_view pass) const {
  Pinned<State> pinned(live_->epochs, live_->current);
  return (*pinned).index.passes[find_pass(*pinned, pass)].variant_count;
}

std::vector<std::vector<std::string>> PackReader::keyword_groups(std::string_view pass_name) const {
  Pinned<State> pinned(live_->epochs, live_->current);
  const runtime::Index& index = (*pinned).index;
  const runtime::Pass& pass = index.passes[find_pass(*pinned, pass_name)];
  std::vector<std::vector<std::string>> groups;
  for (uint32_t g = 0; g < pass.group_count; ++g) {
    const runtime::Group& group = index.groups[pass.first_group + g];
    std::vector<std::string>& values = groups.emplace_back();
    for (uint32_t v = 0; v < group.value_count; ++v) {
      const uint32_t id = index.values[group.first_value + v];
      values.emplace_back(id == runtime::kOffValue ? std::string_view() : index.keywords[id]);
    }
  }
  return groups;
}

std::string_view PackReader::blob(uint32_t id) const {
  Pinned<State> pinned(live_->epochs, live_->current);
  return blob_of(*pinned, id);
}

std::string_view PackReader::blob_of(State& state, uint32_t id) {
  if (id >= state.blobs.size()) throw PackError(PackError::Code::Format, "blob id " + std::to_string(id) + " out of range");
  const Blob& b = state.blobs[id];
  const std::string_view stored = state.archive.bytes().substr(b.offset, b.stored_size);
  auto which = [&] { return "blob " + std::to_string(id); };
  if (b.stored_size == b.raw_size) {
    if (state.checked[id].load(std::memory_order_acquire)) return stored;
    if (XXH3_64bits(stored.data(), stored.size()) != b.hash)
      throw PackError(PackError::Code::Checksum, which() + " fails its checksum", state.archive_file);
    state.checked[id].store(1, std::memory_order_release);
    return stored;
  }
  if (const std::string* raw = state.decompressed[id].load(std::memory_order_acquire)) return *raw;
  std::lock_guard lock(state.mutex);
  if (const std::string* raw = state.decompressed[id].load(std::memory_order_acquire)) return *raw;
  const std::string* raw = state.owned.emplace_back(std::make_unique<std::string>(decompress_checked(b, stored, which(), state.archive_file))).get();
  state.decompressed[id].store(raw, std::memory_order_release);
  return *raw;
}

const Reflection& PackReader::reflection(uint32_t id) const {
  Pinned<State> pinned(live_->epochs, live_->current);
  return reflection_of(*pinned, id);
}

const Reflection& PackReader::reflection_of(State& state, uint32_t id) {
  if (id >= state.index.reflections.size())
    throw PackError(PackError::Code::Format, "reflection " + std::to_string(id) + " out of range");
  if (const Reflection* decoded = state.reflections[id].load(std::memory_order_acquire)) return *decoded;
  std::lock_guard lock(state.mutex);
  if (!state.decoded[id]) {
    try {
      state.decoded[id] = std::make_unique<Reflection>(runtime::decode_reflection(state.index.reflections[id]));
    } catch (const runtime::IndexError& error) {
      throw PackError(PackError::Code::Format, "reflection " + std::to_string(id) + ": " + error.what(), state.archive_file);
    }
    state.reflections[id].store(state.decoded[id].get(), std::memory_order_release);
  }
  return *state.decoded[id];
}

SelectedVariant PackReader::variant(std::string_view pass_name, size_t index) const {
  Pinned<State> pinned(live_->epochs, live_->current);
  const uint32_t pass = find_pass(*pinned, pass_name);
  if (index >= (*pinned).index.passes[pass].variant_count) throw PackError(PackError::Code::Format, "variant index out of range");
  return variant_of(*pinned, pass, static_cast<uint32_t>(index));
}

SelectedVariant PackReader::variant_of(State& state, uint32_t pass_id, uint32_t index) const {
  const runtime::Index& ix = state.index;
  const runtime::Pass& pass = ix.passes[pass_id];
  const runtime::Variant& v = ix.variants[pass.first_variant + index];
  SelectedVariant selected;
  selected.pass = std::string(pass.name);
  selected.index = index;
  for (uint32_t k = 0; k < v.keyword_count; ++k) selected.keywords.emplace_back(ix.keywords[ix.variant_keywords[v.first_keyword + k]]);
  for (Stage stage : kAllStages) {
    const uint32_t binary_id = v.binaries[static_cast<size_t>(stage)];
    if (binary_id == runtime::kNone) continue;
    const runtime::Binary& binary = ix.binaries[binary_id];  // in range: Index::decode
    StageView view;
    view.stage = std::string(stage_name(stage));
    view.entry_point = std::string(binary.entry);
    for (const TargetName& target : kTargetNames)
      if (const uint32_t blob_id = binary.blobs[static_cast<size_t>(target.target)]; blob_id != runtime::kNone)
        view.code(target.target) = blob_of(state, blob_id);
    view.reflection = &reflection_of(state, binary.reflection);
    selected.stages.push_back(view);
  }
  const std::vector<bool> on = ix.folded_on(pass, v);
  for (uint32_t f = 0; f < pass.folded_count; ++f) {
    const runtime::Folded& folded = ix.folded[pass.first_folded + f];
    KeywordValue value;
    if (folded.keyword != runtime::kOffValue) value.keyword = std::string(ix.keywords[folded.keyword]);
    value.kind = folded.kind;
    value.stages = folded.stages;
    value.slot = folded.slot;
    value.value = folded.value;
    value.fallback = folded.fallback;
    value.on = on[f];
    selected.values.push_back(std::move(value));
  }
  return selected;
}

SelectedVariant PackReader::select(std::string_view pass_name, const std::vector<std::string>& keywords, bool strict) const {
  Pinned<State> pinned(live_->epochs, live_->current);
  return select_in(*pinned, pass_name, keywords, strict);
}

SelectedVariant PackReader::select_in(State& state, std::string_view pass_name, const std::vector<std::string>& keywords,
                                      bool strict) const {
  const runtime::Index& ix = state.index;
  const uint32_t pass_id = find_pass(state, pass_name);
  const runtime::Pass& pass = ix.passes[pass_id];
  auto group_values = [&](uint32_t g) {
    const runtime::Group& group = ix.groups[pass.first_group + g];
    return std::span<const uint32_t>(ix.values.data() + group.first_value, group.value_count);
  };
  auto value_names = [&](uint32_t g) {
    std::vector<std::string_view> names;
    for (uint32_t id : group_values(g)) names.push_back(id == runtime::kOffValue ? std::string_view() : ix.keywords[id]);
    return names;
  };
  std::vector<uint32_t> chosen;
  std::vector<bool> group_set(pass.group_count, false);
  std::set<std::string> requested(keywords.begin(), keywords.end());
  requested.erase("");
  for (const std::string& keyword : requested) {
    const uint32_t id = ix.keyword_id(keyword);
    bool found = false;
    for (uint32_t g = 0; g < pass.group_count && !found && id < ix.declared_keywords; ++g) {
      auto values = group_values(g);
      if (std::find(values.begin(), values.end(), id) == values.end()) continue;
      found = true;
      if (group_set[g])
        throw PackError(PackError::Code::ConflictingKeywords,
                        "pass '" + std::string(pass_name) + "': keywords of one group requested together, including '" +
                            keyword + "'; a group takes at most one keyword");
      group_set[g] = true;
      chosen.push_back(id);
    }
    if (!found && strict)
      throw PackError(PackError::Code::UnknownKeyword,
                      "pass '" + std::string(pass_name) + "' does not declare keyword '" + keyword + "'");
  }
  for (uint32_t g = 0; g < pass.group_count; ++g) {
    if (group_set[g]) continue;
    auto values = group_values(g);
    if (std::find(values.begin(), values.end(), runtime::kOffValue) == values.end()) {
      if (values.size() == 1) {
        chosen.push_back(values[0]);  // a one-keyword multi_compile is always on
        continue;
      }
      throw PackError(PackError::Code::MissingKeyword, "pass '" + std::string(pass_name) + "' needs one of: " + join(value_names(g)));
    }
  }
  // Declared keyword ids are in name order, so sorting the ids sorts the names.
  std::sort(chosen.begin(), chosen.end());
  chosen.erase(std::unique(chosen.begin(), chosen.end()), chosen.end());
  const auto& by_hash = state.keys[pass_id].by_hash;
  const uint64_t hash = hash_ids(chosen.data(), chosen.size());
  auto keywords_of = [&](uint32_t v) {
    const runtime::Variant& variant = ix.variants[pass.first_variant + v];
    return std::span<const uint32_t>(ix.variant_keywords.data() + variant.first_keyword, variant.keyword_count);
  };
  // Of variants with the same keywords the last one counts, as in a manifest read into a map.
  std::optional<uint32_t> found;
  for (auto it = std::lower_bound(by_hash.begin(), by_hash.end(), std::pair<uint64_t, uint32_t>(hash, 0));
       it != by_hash.end() && it->first == hash; ++it) {
    auto kw = keywords_of(it->second);
    if (std::equal(kw.begin(), kw.end(), chosen.begin(), chosen.end())) found = it->second;
  }
  if (found) {
    live_->count_served(state, pass_id, *found);
    return variant_of(state, pass_id, *found);
  }

  // Stripped: name the requested keywords that no variant of this pass has together with the rest.
  auto names_of = [&](std::span<const uint32_t> ids) {
    std::vector<std::string> names;
    for (uint32_t id : ids) names.emplace_back(ix.keywords[id]);
    std::sort(names.begin(), names.end());
    return names;
  };
  const std::vector<std::string> chosen_names = names_of(chosen);
  std::vector<std::string> missing;
  for (uint32_t id : chosen) {
    bool anywhere = false;
    for (uint32_t v = 0; v < pass.variant_count && !anywhere; ++v) {
      auto kw = keywords_of(v);
      anywhere = std::find(kw.begin(), kw.end(), id) != kw.end();
    }
    if (!anywhere) missing.emplace_back(ix.keywords[id]);
  }
  // Nearest existing variants by symmetric difference, as hints only (one per distinct keyword set).
  std::set<std::pair<size_t, std::string>> nearest;
  for (uint32_t v = 0; v < pass.variant_count; ++v) {
    const std::vector<std::string> kw = names_of(keywords_of(v));
    std::vector<std::string> diff;
    std::set_symmetric_difference(kw.begin(), kw.end(), chosen_names.begin(), chosen_names.end(), std::back_inserter(diff));
    nearest.emplace(diff.size(), join(kw));
  }
  if (UsageRecorder* usage = live_->recording.load(std::memory_order_acquire)) {
    std::lock_guard lock(usage->mutex);
    auto key = std::make_pair(std::string(pass.name), chosen_names);
    auto it = usage->missing.find(key);
    if (it != usage->missing.end()) {
      ++it->second.count;
    } else if (usage->missing.size() < usage->options.max_missing) {
      std::vector<std::string> nearest_keywords;
      if (!nearest.empty())
        for (size_t v = 0; v < pass.variant_count; ++v)
          if (join(names_of(keywords_of(static_cast<uint32_t>(v)))) == nearest.begin()->second) {
            nearest_keywords = names_of(keywords_of(static_cast<uint32_t>(v)));
            break;
          }
      usage->missing.emplace(std::move(key), UsageRecorder::Missing{1, std::move(nearest_keywords)});
    } else {
      ++usage->missing_dropped;
    }
  }
  std::string message = "pass '" + std::string(pass_name) + "' has no variant [" + join(chosen_names) +
                        "]: it was stripped from pack '" + name_ + "' (constraints, scene profiles or budget)";
  if (!missing.empty()) message += "; no variant at all has: " + join(missing);
  if (!nearest.empty()) {
    message += "; nearest variants in the pack:";
    size_t shown = 0;
    for (auto it = nearest.begin(); it != nearest.end() && shown < 3; ++it, ++shown) message += " [" + it->second + "]";
  }
  throw PackError(PackError::Code::Stripped, message);
}

namespace {
// Runs `call` and hands back its value, or the PackError it threw; the reader's own calls throw nothing else but
// std::bad_alloc, which is the pack's OutOfMemory.
template <class Call>
auto without_exceptions(const std::string& file, Call call) noexcept -> PackResult<decltype(call())> {
  try {
    return call();
  } catch (const PackError& error) {
    return {error.code(), error.what(), error.file()};
  } catch (const std::bad_alloc&) {
    return {PackError::Code::OutOfMemory, "out of memory", file};
  } catch (const std::exception& error) {  // not expected: a reader's error is a PackError
    return {PackError::Code::Format, error.what(), file};
  }
}
}  // namespace

PackResult<PackReader> PackReader::try_open(const std::filesystem::path& path, Check check) noexcept {
  return without_exceptions(path.string(), [&] { return open(path, check); });
}

PackResult<SelectedVariant> PackReader::try_select(std::string_view pass, const std::vector<std::string>& keywords,
                                                   bool strict) const noexcept {
  return without_exceptions({}, [&] { return select(pass, keywords, strict); });
}

PackResult<SelectedVariant> PackReader::try_variant(std::string_view pass, size_t index) const noexcept {
  return without_exceptions({}, [&] { return variant(pass, index); });
}

PackResult<size_t> PackReader::try_variant_count(std::string_view pass) const noexcept {
  return without_exceptions({}, [&] { return variant_count(pass); });
}

PackResult<std::vector<std::vector<std::string>>> PackReader::try_keyword_groups(std::string_view pass) const noexcept {
  return without_exceptions({}, [&] { return keyword_groups(pass); });
}

PackResult<std::string_view> PackReader::try_blob(uint32_t id) const noexcept {
  return without_exceptions({}, [&] { return blob(id); });
}

PackResult<const Reflection*> PackReader::try_reflection(uint32_t id) const noexcept {
  return without_exceptions({}, [&] { return &reflection(id); });
}

// ---- Live updates -------------------------------------------------------------------------------------------------

namespace {

// A variant's binary identity: per stage its entry point, each target's blob (checksum and size, from the blob
// table the head checksum covers) and its reflection record; then its folded keywords' values. What a pipeline is
// made of, so two variants with one identity make the same pipeline.
uint64_t variant_identity(const runtime::Index& ix, const std::vector<Blob>& blobs, const runtime::Pass& pass,
                          const runtime::Variant& variant) {
  std::string bytes;
  auto put = [&](uint64_t value) {
    for (int i = 0; i < 8; ++i) bytes.push_back(static_cast<char>(value >> (8 * i)));
  };
  auto put_text = [&](std::string_view text) {
    put(text.size());
    bytes += text;
  };
  for (size_t stage = 0; stage < kStageCount; ++stage) {
    const uint32_t id = variant.binaries[stage];
    put(id == runtime::kNone ? 0 : 1);
    if (id == runtime::kNone) continue;
    const runtime::Binary& binary = ix.binaries[id];
    put_text(binary.entry);
    for (size_t target = 0; target < kTargetCount; ++target) {
      const uint32_t blob = binary.blobs[target];
      put(blob == runtime::kNone || blob >= blobs.size() ? 0 : 1);  // ids in range: Index::decode; checked again as cheap
      if (blob == runtime::kNone || blob >= blobs.size()) continue;
      put(blobs[blob].hash);
      put(blobs[blob].raw_size);
    }
    put_text(binary.reflection < ix.reflections.size() ? ix.reflections[binary.reflection] : std::string_view());
  }
  const std::vector<bool> on = ix.folded_on(pass, variant);
  for (uint32_t f = 0; f < pass.folded_count; ++f) {
    const runtime::Folded& folded = ix.folded[pass.first_folded + f];
    put_text(folded.keyword == runtime::kOffValue ? std::string_view() : ix.keywords[folded.keyword]);
    put(static_cast<uint64_t>(folded.kind));
    put(static_cast<uint64_t>(folded.stages));
    put(folded.slot);
    put(folded.value);
    put(folded.fallback);
    put(on[f] ? 1 : 0);
  }
  return XXH3_64bits(bytes.data(), bytes.size());
}

// A pass's variants by keyword set; of variants with the same keywords the last one, as select() takes.
std::map<std::vector<std::string>, uint32_t> variants_by_keywords(const runtime::Index& ix, const runtime::Pass& pass) {
  std::map<std::vector<std::string>, uint32_t> out;
  for (uint32_t v = 0; v < pass.variant_count; ++v) {
    const runtime::Variant& variant = ix.variants[pass.first_variant + v];
    std::vector<std::string> keywords;
    for (uint32_t k = 0; k < variant.keyword_count; ++k)
      keywords.emplace_back(ix.keywords[ix.variant_keywords[variant.first_keyword + k]]);
    out[std::move(keywords)] = v;
  }
  return out;
}

const runtime::Pass* pass_named(const runtime::Index& ix, std::string_view name) {
  for (const runtime::Pass& pass : ix.passes)
    if (pass.name == name) return &pass;
  return nullptr;
}

void drain(int fd) {
  alignas(inotify_event) char buffer[4096];
  while (::read(fd, buffer, sizeof buffer) > 0) {
  }
}

}  // namespace

PackResult<PackUpdate> PackReader::poll_update() noexcept {
  Live& live = *live_;
  try {
    std::lock_guard lock(live.mutex);
    ++live.polls;
    live.reclaim();
    if (live.inotify >= 0) drain(live.inotify);
    State& old = *live.current_owner;
    PackUpdate update;
    update.version = live.version;
    update.archive = std::filesystem::path(old.archive_file).filename().string();
    const std::string manifest_name = live.manifest_file.string();
    // The cheap answer, every frame: the manifest is the file this version was read from.
    FileIdentity now = FileIdentity::at(manifest_name);
    if (now == live.seen) return update;
    if (live.refused && now == live.refused_manifest && FileIdentity::at(live.refused_archive_file) == live.refused_archive)
      return update;  // refused already, and reported
    auto refuse = [&](const FileIdentity& manifest, const std::string& archive_file, const PackError& error) {
      live.refused = true;
      live.refused_manifest = manifest;
      live.refused_archive_file = archive_file;
      live.refused_archive = archive_file.empty() ? FileIdentity{} : FileIdentity::at(archive_file);
      return PackResult<PackUpdate>(error.code(), error.what(), error.file());
    };
    std::unique_ptr<State> next;
    for (int attempt = 0;; ++attempt) {
      std::string archive_file;
      try {
        next = load(live.manifest_file, Check::OnUse, &archive_file);
        break;
      } catch (const PackError& error) {
        // A build may have renamed a newer manifest into place (and removed the archive the one read names) while it
        // was read: read the newer one. Each manifest is read whole from one file, so an old manifest never meets a
        // new archive; the archive's name is its checksum.
        const FileIdentity after = FileIdentity::at(manifest_name);
        if (attempt < 3 && after != now) {
          now = after;
          if (now == live.seen) return update;
          continue;
        }
        return refuse(now, archive_file, error);
      } catch (const std::bad_alloc&) {
        return refuse(now, archive_file,
                      PackError(PackError::Code::OutOfMemory, "the new pack does not fit in the memory this process may use",
                                manifest_name));
      }
    }
    live.refused = false;
    if (next->name != old.name)
      return refuse(now, next->archive_file,
                    PackError(PackError::Code::Format,
                              "the new manifest is of pack '" + next->name + "', not '" + old.name + "' that this reader serves",
                              manifest_name));
    if (next->archive_file == old.archive_file && next->manifest_text.bytes() == old.manifest_text.bytes()) {
      live.seen = next->manifest_text.identity();  // the same pack written again: nothing to switch
      return update;
    }

    for (State* version : {&old, next.get()}) {
      if (!version->identities.empty()) continue;
      const runtime::Index& ix = version->index;
      version->identities.resize(ix.variants.size());
      for (const runtime::Pass& pass : ix.passes)
        for (uint32_t v = 0; v < pass.variant_count; ++v)
          version->identities[pass.first_variant + v] = variant_identity(ix, version->blobs, pass, ix.variants[pass.first_variant + v]);
    }
    const runtime::Index &was = old.index, &is = next->index;
    auto change = [&](VariantChange::Kind kind, const std::string& pass, const std::vector<std::string>& keywords,
                      size_t old_index, size_t new_index) {
      update.changes.push_back({kind, pass, keywords, old_index, new_index});
    };
    for (const runtime::Pass& pass : is.passes) {
      const std::string name(pass.name);
      const runtime::Pass* before = pass_named(was, pass.name);
      const auto now_variants = variants_by_keywords(is, pass);
      const auto old_variants = before ? variants_by_keywords(was, *before) : std::map<std::vector<std::string>, uint32_t>{};
      auto a = old_variants.begin();
      auto b = now_variants.begin();
      while (a != old_variants.end() || b != now_variants.end()) {
        if (b == now_variants.end() || (a != old_variants.end() && a->first < b->first)) {
          change(VariantChange::Kind::Removed, name, a->first, a->second, VariantChange::kNoIndex);
          ++a;
        } else if (a == old_variants.end() || b->first < a->first) {
          change(VariantChange::Kind::Added, name, b->first, VariantChange::kNoIndex, b->second);
          ++b;
        } else {
          if (old.identities[before->first_variant + a->second] != next->identities[pass.first_variant + b->second])
            change(VariantChange::Kind::Changed, name, b->first, a->second, b->second);
          else if (a->second != b->second)
            change(VariantChange::Kind::Moved, name, b->first, a->second, b->second);
          ++a;
          ++b;
        }
      }
    }
    for (const runtime::Pass& pass : was.passes)
      if (!pass_named(is, pass.name))
        for (const auto& [keywords, index] : variants_by_keywords(was, pass))
          change(VariantChange::Kind::Removed, std::string(pass.name), keywords, index, VariantChange::kNoIndex);
    update.ids_changed = was.passes.size() != is.passes.size() || was.declared_keywords != is.declared_keywords ||
                         !std::equal(was.passes.begin(), was.passes.end(), is.passes.begin(), is.passes.end(),
                                     [](const runtime::Pass& x, const runtime::Pass& y) { return x.name == y.name; }) ||
                         !std::equal(was.keywords.begin(), was.keywords.begin() + was.declared_keywords, is.keywords.begin());

    // The switch: counted from its first selection, then published; the version replaced stays until reclaim() frees it.
    if (live.usage) {
      next->counts = counts_for(is);
      next->served.store(next->counts.get(), std::memory_order_release);
    }
    live.seen = next->manifest_text.identity();
    live.current.store(next.get(), std::memory_order_seq_cst);
    live.retired.push_back({std::move(live.current_owner), live.epochs.epoch(), live.polls});
    live.current_owner = std::move(next);
    ++live.version;
    live.epochs.try_advance();
    update.switched = true;
    update.version = live.version;
    update.archive = std::filesystem::path(live.current_owner->archive_file).filename().string();
    return update;
  } catch (const PackError& error) {
    return {error.code(), error.what(), error.file()};
  } catch (const std::bad_alloc&) {
    return {PackError::Code::OutOfMemory, "out of memory looking for a new pack", live.manifest_file.string()};
  } catch (const std::exception& error) {
    return {PackError::Code::Io, error.what(), live.manifest_file.string()};
  }
}

PackReader::Pin::Pin(Live* live) noexcept : live_(live), stripe_(thread_stripe()), parity_(live->epochs.enter(stripe_)) {}
PackReader::Pin::Pin(Pin&& other) noexcept
    : live_(std::exchange(other.live_, nullptr)), stripe_(other.stripe_), parity_(other.parity_) {}
PackReader::Pin::~Pin() {
  if (live_) live_->epochs.leave(stripe_, parity_);
}
PackReader::Pin PackReader::pin() const noexcept { return Pin(live_.get()); }

PackResult<int> PackReader::update_fd() noexcept {
  Live& live = *live_;
  std::lock_guard lock(live.mutex);
  if (live.inotify >= 0) return live.inotify;
  std::string directory = live.manifest_file.parent_path().string();
  if (directory.empty()) directory = ".";
  const int fd = ::inotify_init1(IN_NONBLOCK | IN_CLOEXEC);
  if (fd < 0) return PackResult<int>(PackError::Code::Io, std::string("inotify: ") + std::strerror(errno), directory);
  // A build renames its files into place; a copy closes them after writing; a removal is news too.
  if (::inotify_add_watch(fd, directory.c_str(), IN_MOVED_TO | IN_CLOSE_WRITE | IN_DELETE | IN_MOVED_FROM) < 0) {
    const int error = errno;
    ::close(fd);
    return PackResult<int>(PackError::Code::Io, std::string("inotify: ") + std::strerror(error), directory);
  }
  live.inotify = fd;
  return fd;
}

}  // namespace kiln
