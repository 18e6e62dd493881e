// SPDX-License-Identifier: Apache-2.0
#include "cache/cache.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <functional>
#include <set>

#include "common/bytes.hpp"
#include "common/files.hpp"

namespace kiln {
namespace {

// An entry's record: magic, format, kind, key, payload size, payload checksum, payload. The same record
// whether it sits in the segment a build wrote or in the one a later merge wrote.
constexpr char kRecordMagic[8] = {'K', 'I', 'L', 'N', 'C', 'A', 'C', 'H'};
// 2: entries are results or aliases (a stage source's key naming its front-end module's entry).
// 3: entries live in segment files.
constexpr uint32_t kCacheFormat = 3;
constexpr size_t kRecordHeaderSize = 8 + 4 + 4 + 16 + 8 + 8;
enum EntryKind : uint32_t { kResult = 0, kAlias = 1, kMemo = 2 };

// A segment: magic, format, entry count, index offset, index checksum; the records; the index (key, offset,
// size per record, ordered by key). The file ends where the index does: a truncated segment is refused.
constexpr char kSegmentMagic[8] = {'K', 'I', 'L', 'N', 'S', 'E', 'G', 'M'};
constexpr size_t kSegmentHeaderSize = 8 + 4 + 4 + 8 + 8;
constexpr size_t kIndexEntrySize = 16 + 8 + 8;
constexpr const char* kSegmentExtension = ".kseg";


bool read_exactly(int fd, uint64_t offset, std::string& out, uint64_t size) {
  out.resize(size);
  uint64_t done = 0;
  while (done < size) {
    ssize_t got = ::pread(fd, out.data() + done, size - done, static_cast<off_t>(offset + done));
    if (got < 0 && errno == EINTR) continue;
    if (got <= 0) return false;
    done += static_cast<uint64_t>(got);
  }
  return true;
}

// The record's kind when its header, key and checksum are right; its payload in `payload`.
std::optional<uint32_t> check_record(std::string_view record, const Hash128& key, std::string_view* payload) {
  if (record.size() < kRecordHeaderSize || std::memcmp(record.data(), kRecordMagic, 8) != 0) return std::nullopt;
  const uint32_t format = get32(record, 8), kind = get32(record, 12);
  if (format != kCacheFormat || kind > kMemo) return std::nullopt;
  if (get64(record, 16) != key.low || get64(record, 24) != key.high) return std::nullopt;
  if (get64(record, 32) != record.size() - kRecordHeaderSize) return std::nullopt;
  std::string_view body = record.substr(kRecordHeaderSize);
  if (hash64(body) != get64(record, 40)) return std::nullopt;
  if (payload) *payload = body;
  return kind;
}

// The regular files directly in `directory` with their size and modification time (none when it cannot
// be read; a file removed meanwhile is left out).
struct DirectoryFile {
  std::filesystem::path path;
  uint64_t size;
  std::filesystem::file_time_type written;
};
std::vector<DirectoryFile> files_in(const std::filesystem::path& directory) {
  std::vector<DirectoryFile> files;
  std::error_code ec;
  for (auto it = std::filesystem::directory_iterator(directory, ec); !ec && it != std::filesystem::directory_iterator();
       it.increment(ec)) {
    std::error_code file_ec;
    if (!it->is_regular_file(file_ec)) continue;
    DirectoryFile file{it->path(), it->file_size(file_ec), it->last_write_time(file_ec)};
    if (!file_ec) files.push_back(std::move(file));
  }
  std::sort(files.begin(), files.end(), [](const DirectoryFile& a, const DirectoryFile& b) { return a.path < b.path; });
  return files;
}

bool is_segment(const std::filesystem::path& path) { return path.extension() == kSegmentExtension; }

}  // namespace

Cache::Cache(std::filesystem::path directory, uint64_t max_bytes)
    : directory_(std::move(directory)), max_bytes_(max_bytes) {}

Cache::~Cache() { close_segments(); }

void Cache::close_segments() {
  for (Segment& s : segments_)
    if (s.fd >= 0) ::close(s.fd);
  segments_.clear();
  index_.clear();
  scanned_ = false;
}

void Cache::scan() {
  std::set<std::filesystem::path> damaged, used;  // what loads found since the last scan still holds
  for (const Segment& s : segments_) {
    if (s.damaged) damaged.insert(s.path);
    if (s.used) used.insert(s.path);
  }
  close_segments();
  scanned_ = true;
  for (const DirectoryFile& file : files_in(directory_)) {
    if (!is_segment(file.path)) continue;
    const std::filesystem::path& path = file.path;
    // Opened once and kept: a merge in another build may remove the file, not what this build reads.
    int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) continue;  // removed by a merge since the listing
    struct stat st {};
    Segment segment{path, fd, 0, false, damaged.count(path) > 0, used.count(path) > 0};
    const size_t index = segments_.size();
    segments_.push_back(segment);
    std::string header, entries;
    if (::fstat(fd, &st) != 0 || !read_exactly(fd, 0, header, kSegmentHeaderSize) ||
        std::memcmp(header.data(), kSegmentMagic, 8) != 0 || get32(header, 8) != kCacheFormat) {
      segments_[index].unreadable = segments_[index].damaged = true;
      continue;
    }
    const uint64_t file_size = static_cast<uint64_t>(st.st_size), count = get32(header, 12),
                   index_offset = get64(header, 16);
    segments_[index].size = file_size;
    if (index_offset < kSegmentHeaderSize || index_offset > file_size ||
        (file_size - index_offset) != count * kIndexEntrySize || !read_exactly(fd, index_offset, entries, count * kIndexEntrySize) ||
        hash64(entries) != get64(header, 24)) {
      segments_[index].unreadable = segments_[index].damaged = true;
      continue;
    }
    for (uint64_t i = 0; i < count; ++i) {
      const size_t at = i * kIndexEntrySize;
      const uint64_t offset = get64(entries, at + 16), size = get64(entries, at + 24);
      if (offset < kSegmentHeaderSize || offset > index_offset || size > index_offset - offset) {
        segments_[index].damaged = true;
        continue;
      }
      index_[Hash128{get64(entries, at), get64(entries, at + 8)}].push_back({index, offset, size});
    }
  }
}

std::optional<std::string> Cache::read_record(const Location& at) {
  std::string record;
  if (!read_exactly(segments_[at.segment].fd, at.offset, record, at.size)) return std::nullopt;
  return record;
}

Cache::Copy Cache::visit_copies(const Hash128& key, const std::function<Copy(uint32_t, std::string_view)>& visit) {
  if (!scanned_) scan();
  auto found = index_.find(key);
  if (found == index_.end()) return Copy::Skip;
  bool bad = false;
  Copy result = Copy::Skip;
  for (const Location& at : found->second) {
    std::optional<std::string> record = read_record(at);
    std::string_view payload;
    std::optional<uint32_t> kind = record ? check_record(*record, key, &payload) : std::nullopt;
    const Copy verdict = kind ? visit(*kind, payload) : Copy::Bad;
    if (verdict == Copy::Take) {
      segments_[at.segment].used = true;
      result = Copy::Take;
      break;
    }
    if (verdict == Copy::Bad) {
      bad = true;
      segments_[at.segment].damaged = true;  // the next commit copies its good entries out and removes it
    }
  }
  if (bad) ++rejected_loads_;
  return result;
}

std::optional<Cache::Entry> Cache::read(const Hash128& key) {
  // Every good copy of an entry has the same bytes (same key, deterministic compile); the first good one wins.
  Entry entry;
  auto decode = [&](uint32_t kind, std::string_view payload) {
    if (kind == kMemo) return Copy::Skip;  // a memo's key is never a result's or an alias's
    entry = Entry{};
    if (kind == kAlias) {
      if (payload.size() < 16) return Copy::Bad;
      entry.alias = Hash128{get64(payload, 0), get64(payload, 8)};
      payload.remove_prefix(16);
    }
    try {
      entry.output = decode_output(std::vector<uint8_t>(payload.begin(), payload.end()));
    } catch (const std::exception&) {
      return Copy::Bad;
    }
    return entry.output.ok ? Copy::Take : Copy::Bad;
  };
  if (visit_copies(key, decode) == Copy::Take) return entry;
  return std::nullopt;
}

namespace {

std::optional<PreprocessMemo> decode_memo(std::string_view p) {
  PreprocessMemo memo;
  if (p.size() < 20) return std::nullopt;
  memo.source_key = Hash128{get64(p, 0), get64(p, 8)};
  const uint32_t count = get32(p, 16);
  size_t at = 20;
  for (uint32_t i = 0; i < count; ++i) {
    if (p.size() - at < 4) return std::nullopt;
    const uint32_t length = get32(p, at);
    if (p.size() - at - 4 < uint64_t{length} + 8) return std::nullopt;
    memo.files.emplace_back(std::string(p.substr(at + 4, length)), get64(p, at + 4 + length));
    at += 4 + length + 8;
  }
  if (at != p.size()) return std::nullopt;
  return memo;
}

}  // namespace

// Unlike results, one memo key can hold different memos (the same source before and after an edit), in
// different segments: each copy is offered until one is accepted.
std::optional<PreprocessMemo> Cache::load_memo(const Hash128& key, const std::function<bool(const PreprocessMemo&)>& accept) {
  std::lock_guard lock(mutex_);
  std::optional<PreprocessMemo> memo;
  auto offer = [&](uint32_t kind, std::string_view payload) {
    memo = kind == kMemo ? decode_memo(payload) : std::nullopt;
    if (!memo) return Copy::Bad;
    return accept(*memo) ? Copy::Take : Copy::Skip;
  };
  if (visit_copies(key, offer) == Copy::Take) return memo;
  return std::nullopt;
}

bool Cache::store_memo(const Hash128& key, const PreprocessMemo& memo) {
  std::string payload;
  put64(payload, memo.source_key.low);
  put64(payload, memo.source_key.high);
  put32(payload, static_cast<uint32_t>(memo.files.size()));
  for (const auto& [name, hash] : memo.files) {
    put32(payload, static_cast<uint32_t>(name.size()));
    payload += name;
    put64(payload, hash);
  }
  stage_record(key, kMemo, payload);
  return true;
}

std::optional<JobOutput> Cache::load(const Hash128& key, std::optional<Hash128>* target_key) {
  std::lock_guard lock(mutex_);
  if (target_key) target_key->reset();
  std::optional<Entry> entry = read(key);
  if (!entry || !entry->alias) return entry ? std::optional<JobOutput>(std::move(entry->output)) : std::nullopt;
  std::optional<Entry> target = read(*entry->alias);
  if (!target || target->alias) {
    if (target) ++rejected_loads_;  // an alias to an alias is not something kiln writes: rejected, not followed
    return std::nullopt;
  }
  if (target_key) *target_key = entry->alias;
  JobOutput output = std::move(target->output);
  std::vector<FrontendMessage>& front = entry->output.messages;
  output.messages.insert(output.messages.begin(), front.begin(), front.end());
  return output;
}

void Cache::stage_record(const Hash128& key, uint32_t kind, std::string_view payload) {
  std::string record(kRecordMagic, 8);
  put32(record, kCacheFormat);
  put32(record, kind);
  put64(record, key.low);
  put64(record, key.high);
  put64(record, payload.size());
  put64(record, hash64(payload));
  record += payload;
  std::lock_guard lock(mutex_);
  staged_[key] = std::move(record);
}

bool Cache::stage(const Hash128& key, uint32_t kind, std::string_view prefix, const JobOutput& output) {
  std::vector<uint8_t> encoded = encode_output(output);
  std::string payload(prefix);
  payload.append(reinterpret_cast<const char*>(encoded.data()), encoded.size());
  stage_record(key, kind, payload);
  return true;
}

bool Cache::store(const Hash128& key, const JobOutput& output) {
  if (!output.ok) return false;
  return stage(key, kResult, {}, output);
}

bool Cache::store_alias(const Hash128& key, const Hash128& target, const std::vector<FrontendMessage>& messages) {
  JobOutput front;
  front.ok = true;
  front.messages = messages;
  std::string prefix;
  put64(prefix, target.low);
  put64(prefix, target.high);
  return stage(key, kAlias, prefix, front);
}

// A build killed while writing its segment leaves the temporary file behind; one an hour old is abandoned
// (a live build writes its segment in well under a second).
void Cache::remove_abandoned_temporaries() {
  const auto now = std::filesystem::file_time_type::clock::now();
  std::error_code ec;
  for (const DirectoryFile& file : files_in(directory_))
    if (file.path.filename().string().find(std::string(kSegmentExtension) + ".tmp.") != std::string::npos &&
        now - file.written > std::chrono::hours(1))
      std::filesystem::remove(file.path, ec);
}

// Used segments get the current time as their modification time: the order of eviction.
void Cache::mark_used_segments() {
  for (const Segment& s : segments_)
    if (s.used && s.fd >= 0) ::futimens(s.fd, nullptr);
}

void Cache::evict_least_recently_used(const std::filesystem::path& keep) {
  std::vector<DirectoryFile> candidates;
  uint64_t total = 0;
  for (DirectoryFile& file : files_in(directory_)) {
    if (!is_segment(file.path)) continue;
    total += file.size;
    if (file.path != keep) candidates.push_back(std::move(file));
  }
  std::stable_sort(candidates.begin(), candidates.end(),
                   [](const DirectoryFile& a, const DirectoryFile& b) { return a.written < b.written; });
  std::error_code ec;
  for (const DirectoryFile& c : candidates) {
    if (total <= max_bytes_) break;
    if (std::filesystem::remove(c.path, ec)) total -= c.size;
  }
}

Result<void> Cache::commit() {
  std::lock_guard lock(mutex_);
  if (!scanned_ && staged_.empty()) return {};  // nothing loaded, nothing to write
  mark_used_segments();
  if (staged_.empty()) {
    evict_least_recently_used({});
    close_segments();
    return {};
  }
  std::error_code ec;
  std::filesystem::create_directories(directory_, ec);
  if (ec) return failure("cannot create the cache directory '" + directory_.string() + "': " + ec.message());
  scan();  // what other builds committed meanwhile counts too
  remove_abandoned_temporaries();

  // Merged into the new segment, then removed: damaged segments (their good entries are kept), and when
  // there are too many, every segment but the largest good one, so the bulk of a cache is not rewritten.
  std::vector<size_t> merged;
  const bool too_many = segments_.size() + 1 > kMaxSegments;
  size_t largest = segments_.size();
  for (size_t s = 0; s < segments_.size(); ++s)
    if (!segments_[s].damaged && (largest == segments_.size() || segments_[s].size > segments_[largest].size)) largest = s;
  for (size_t s = 0; s < segments_.size(); ++s)
    if (segments_[s].damaged || (too_many && s != largest)) merged.push_back(s);
  std::map<Hash128, std::string> records = std::move(staged_);
  staged_.clear();
  for (const auto& [key, locations] : index_)
    for (const Location& at : locations)
      if (std::find(merged.begin(), merged.end(), at.segment) != merged.end() && !records.count(key))
        if (std::optional<std::string> record = read_record(at); record && check_record(*record, key, nullptr))
          records.emplace(key, std::move(*record));

  std::string header(kSegmentMagic, 8), index;
  std::vector<std::string_view> parts(1);  // the header, once complete
  uint64_t offset = kSegmentHeaderSize;
  for (const auto& [key, record] : records) {
    put64(index, key.low);
    put64(index, key.high);
    put64(index, offset);
    put64(index, record.size());
    parts.push_back(record);
    offset += record.size();
  }
  put32(header, kCacheFormat);
  put32(header, static_cast<uint32_t>(records.size()));
  put64(header, offset);
  put64(header, hash64(index));
  parts.front() = header;
  parts.push_back(index);
  // The header, the index and each record's checksum name the content.
  std::string checksums;
  for (const auto& [key, record] : records) checksums.append(record, 40, 8);
  const std::string name = "seg-" + hash128(header + index + checksums).hex() + kSegmentExtension;
  Result<void> written = write_output_file(directory_ / name, parts);
  if (written) {
    for (size_t s : merged)
      if (segments_[s].path.filename() != name) std::filesystem::remove(segments_[s].path, ec);
    evict_least_recently_used(directory_ / name);
  }
  close_segments();  // the next load sees the new segment
  return written;
}

size_t Cache::unreadable_segments() {
  std::lock_guard lock(mutex_);
  if (!scanned_) scan();
  return static_cast<size_t>(std::count_if(segments_.begin(), segments_.end(), [](const Segment& s) { return s.unreadable; }));
}

size_t Cache::indexed_keys() {
  std::lock_guard lock(mutex_);
  if (!scanned_) scan();
  return index_.size();
}

std::vector<std::filesystem::path> Cache::segment_files() {
  std::lock_guard lock(mutex_);
  if (!scanned_) scan();
  std::vector<std::filesystem::path> paths;
  for (const Segment& s : segments_) paths.push_back(s.path);
  return paths;
}

}  // namespace kiln
