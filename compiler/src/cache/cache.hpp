// SPDX-License-Identifier: Apache-2.0
// Content-addressed cache of compile results. The key covers kiln's version, the exact tool versions,
// every option, the stage, the entry point and the preprocessed text, so an include edit misses
// exactly the variants that read it. Two kinds of entry: a back end's result, keyed by the front end's
// SPIR-V module (plus the same versions and options), and for each stage source an alias naming its
// module's entry and carrying the front end's warnings; so an edit that changes no code the entry point
// reaches costs a front end, not a back end.
//
// Storage: segment files. A build stages its new entries in memory and commit() writes them as one
// segment (`seg-<content hash>.kseg`: a header, the entries, an index of keys and offsets, each part
// checksummed), by temp file and rename: one file per build instead of one per entry, because creating
// thousands of small files is what a cold build's cache store cost on ext4 (see docs/design.md).
// Segments are never modified. When a commit finds more than kMaxSegments, it merges every segment but
// the largest (and any found damaged) into the new one and removes them; readers keep the segments they
// opened, so a concurrent build reading a removed segment still reads it. Entries carry their own key
// and checksum; a corrupt, truncated or foreign entry (or an alias whose target is any of those) is a
// miss, rewritten by the next commit; a segment whose header or index fails its checks is skipped whole.
// Two builds writing the same entries write the same segment bytes under the same name (the name hashes
// the index and every record's checksum). A temporary
// segment an hour old (its build was killed while writing it) is removed by the next commit.
// Size limit: a commit marks the segments the build read from as used (their modification time), and when
// the segments take more than the limit, removes the least recently used ones (never the one it wrote)
// until they fit. Entries of a removed segment are misses, compiled again by the build that needs them.
#pragma once

#include <filesystem>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "common/hash.hpp"
#include "common/compile_result.hpp"
#include "kiln/result.hpp"

namespace kiln {

// What preprocessing one stage source gave, without its text: the source's cache key (the hash of the
// text with the versions, options, stage and entry point), and every file it read (display name, XXH3 of
// the text). Valid while each of those files has the same hash.
struct PreprocessMemo {
  Hash128 source_key;
  std::vector<std::pair<std::string, uint64_t>> files;
};

class Cache {
 public:
  static constexpr size_t kMaxSegments = 8;
  static constexpr uint64_t kDefaultMaxBytes = uint64_t{1} << 30;

  explicit Cache(std::filesystem::path directory, uint64_t max_bytes = kDefaultMaxBytes);
  ~Cache();
  Cache(const Cache&) = delete;
  Cache& operator=(const Cache&) = delete;
  const std::filesystem::path& directory() const { return directory_; }

  // Nothing on a miss. An alias is followed: the result is its target's, with the alias's messages first, and
  // `target` (if given) is set to the target's key. Sees the segments committed when it is first called (after a
  // commit, again). A copy of the entry that fails its checks is a miss, and counts in rejected_loads().
  std::optional<JobOutput> load(const Hash128& key, std::optional<Hash128>* target = nullptr);
  // Staged in memory until commit(); safe to call from many threads. Only successful results are ever
  // stored: a failure (or a crash) is never cached.
  bool store(const Hash128& key, const JobOutput& output);
  bool store_alias(const Hash128& key, const Hash128& target, const std::vector<FrontendMessage>& messages);
  // A third kind of entry, under keys of their own: preprocessing memos (staged like the others).
  // The first memo under `key` that `accept` takes (one key can hold several: see load_memo). Damaged copies as
  // for load().
  std::optional<PreprocessMemo> load_memo(const Hash128& key, const std::function<bool(const PreprocessMemo&)>& accept);
  bool store_memo(const Hash128& key, const PreprocessMemo& memo);
  // Marks the segments loads were served from as used; writes the staged entries as one segment (nothing
  // when none are staged); then keeps the cache within its size limit. The error says what failed.
  Result<void> commit();

  // Segments whose header or index failed its checks, as of the last scan.
  size_t unreadable_segments();
  // Loads (load, load_memo) that found a copy of their entry failing its checks (corrupt, truncated, foreign), so
  // far; each such copy is rewritten from a good one, or compiled again, at the next commit.
  size_t rejected_loads() {
    std::lock_guard lock(mutex_);
    return rejected_loads_;
  }
  // Distinct keys with an entry in a readable segment (entries themselves are checked when loaded).
  size_t indexed_keys();
  std::vector<std::filesystem::path> segment_files();

 private:
  struct Segment {
    std::filesystem::path path;
    int fd = -1;
    uint64_t size = 0;
    bool unreadable = false;  // its header or index failed its checks
    bool damaged = false;     // unreadable, or an entry it lists failed its checks
    bool used = false;        // an entry was loaded from it
  };
  struct Location {
    size_t segment;
    uint64_t offset;
    uint64_t size;
  };
  struct Entry {
    std::optional<Hash128> alias;
    JobOutput output;  // an alias's: only its messages
  };
  void scan();
  void remove_abandoned_temporaries();
  void mark_used_segments();
  void evict_least_recently_used(const std::filesystem::path& keep);
  void close_segments();
  std::optional<std::string> read_record(const Location& at);
  // Each copy of a key's record that passes its checks goes to `visit` (kind, payload), in segment order,
  // until one is taken; copies that fail their checks, or that `visit` finds bad, are marked damaged; a call that
  // met one counts in rejected_loads_.
  enum class Copy { Take, Skip, Bad };
  Copy visit_copies(const Hash128& key, const std::function<Copy(uint32_t, std::string_view)>& visit);
  std::optional<Entry> read(const Hash128& key);
  bool stage(const Hash128& key, uint32_t kind, std::string_view prefix, const JobOutput& output);
  void stage_record(const Hash128& key, uint32_t kind, std::string_view payload);

  size_t rejected_loads_ = 0;  // under mutex_
  std::filesystem::path directory_;
  uint64_t max_bytes_;
  std::mutex mutex_;
  bool scanned_ = false;
  std::vector<Segment> segments_;
  std::map<Hash128, std::vector<Location>> index_;
  std::map<Hash128, std::string> staged_;  // key -> the entry's record, ordered: the segment's bytes are too
};

}  // namespace kiln
