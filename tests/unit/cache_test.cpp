// SPDX-License-Identifier: Apache-2.0
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>

#include "cache/cache.hpp"
#include "test_support.hpp"

namespace kiln {
namespace {

JobOutput sample_output(const std::string& text = "void main() {}") {
  JobOutput out;
  out.ok = true;
  out.blobs[Target::Spirv] = pack_spirv({0x07230203, 1, 2, 3});
  out.blobs[Target::Glsl] = pack_blob("#version 450\n" + text + "\n");
  out.reflection.outputs.push_back({"color", 0, "float4"});
  return out;
}

// The segment layout, as cache.cpp writes it: a 32-byte header (magic, format, count, index offset, index
// checksum), the records (each a 48-byte header then its payload), the index (key, offset, size per record).
constexpr size_t kSegmentHeader = 32, kRecordHeader = 48, kIndexEntry = 32;

uint64_t get64(const std::string& s, size_t at) {
  uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v |= static_cast<uint64_t>(static_cast<unsigned char>(s[at + i])) << (8 * i);
  return v;
}
void set64(std::string& s, size_t at, uint64_t v) {
  for (int i = 0; i < 8; ++i) s[at + i] = static_cast<char>(v >> (8 * i));
}

std::filesystem::path only_segment(Cache& cache) {
  auto files = cache.segment_files();
  EXPECT_EQ(files.size(), 1u);
  return files.empty() ? std::filesystem::path() : files.front();
}

// A load, and whether it met a copy of its entry that failed its checks (Cache::rejected_loads() grew).
std::optional<JobOutput> load(Cache& cache, const Hash128& key, bool& rejected, std::optional<Hash128>* target = nullptr) {
  const size_t before = cache.rejected_loads();
  std::optional<JobOutput> output = cache.load(key, target);
  rejected = cache.rejected_loads() > before;
  return output;
}

TEST(Cache, StoredEntryLoadsBackIdenticallyAfterCommit) {
  testing::TempDir dir;
  Cache cache(dir.path());
  Hash128 key = hash128("key");
  ASSERT_TRUE(cache.store(key, sample_output()));
  bool rejected = true;
  EXPECT_FALSE(load(cache, key, rejected)) << "staged entries are not in the cache before commit()";
  EXPECT_TRUE(testing::files_below(dir.path()).empty());
  ASSERT_TRUE(cache.commit());
  auto loaded = load(cache, key, rejected);
  ASSERT_TRUE(loaded);
  EXPECT_FALSE(rejected);
  EXPECT_EQ(loaded->blobs, sample_output().blobs);
  EXPECT_EQ(unpack_blob(loaded->blobs.at(Target::Glsl)), "#version 450\nvoid main() {}\n");
  // Another process sees it too.
  Cache other(dir.path());
  EXPECT_TRUE(load(other, key, rejected));
  EXPECT_EQ(testing::files_below(dir.path()).size(), 1u);
}

TEST(Cache, CorruptTruncatedOrForeignEntriesAreMissesAndTheNextCommitRewritesThem) {
  testing::TempDir dir;
  Hash128 key = hash128("key"), other = hash128("other");
  std::filesystem::path segment;
  {
    Cache cache(dir.path());
    ASSERT_TRUE(cache.store(key, sample_output()));
    ASSERT_TRUE(cache.commit());
    segment = only_segment(cache);
  }
  const std::string good = testing::read_file(segment);
  const std::string name = segment.filename().string();
  bool rejected = false;

  // A flipped bit in the entry's payload: its checksum fails.
  std::string corrupt = good;
  corrupt[kSegmentHeader + kRecordHeader + 5] ^= 1;
  dir.write(name, corrupt);
  {
    Cache cache(dir.path());
    EXPECT_FALSE(load(cache, key, rejected));
    EXPECT_TRUE(rejected);
    // Rewriting fixes it: the new segment holds the entry, the damaged one is gone.
    ASSERT_TRUE(cache.store(key, sample_output()));
    ASSERT_TRUE(cache.commit());
    EXPECT_TRUE(load(cache, key, rejected));
    EXPECT_FALSE(rejected);
    EXPECT_EQ(testing::read_file(only_segment(cache)), good);
  }

  // A truncated segment: its index is gone, so the whole segment is skipped (counted, not read).
  dir.write(name, good.substr(0, good.size() - 10));
  {
    Cache cache(dir.path());
    EXPECT_FALSE(load(cache, key, rejected));
    EXPECT_FALSE(rejected);
    EXPECT_EQ(cache.unreadable_segments(), 1u);
    ASSERT_TRUE(cache.store(key, sample_output()));
    ASSERT_TRUE(cache.commit());
    EXPECT_TRUE(load(cache, key, rejected));
    EXPECT_EQ(cache.unreadable_segments(), 0u);
  }

  // A foreign entry: the index names `other` for `key`'s record (index checksum recomputed). The key
  // stored inside the record tells them apart.
  std::string foreign = good;
  const size_t index = get64(good, 16);
  set64(foreign, index, other.low);
  set64(foreign, index + 8, other.high);
  set64(foreign, 24, hash64(std::string_view(foreign).substr(index, kIndexEntry)));
  std::filesystem::remove(dir.path() / name);
  dir.write("seg-foreign.kseg", foreign);
  {
    Cache cache(dir.path());
    EXPECT_EQ(cache.unreadable_segments(), 0u);
    EXPECT_FALSE(load(cache, other, rejected));
    EXPECT_TRUE(rejected);
  }
}

TEST(Cache, AliasServesItsTargetWithItsOwnMessagesFirst) {
  testing::TempDir dir;
  Cache cache(dir.path());
  Hash128 source = hash128("source"), module = hash128("module");
  JobOutput result = sample_output();
  result.messages.push_back({Severity::Warning, "", 0, "from the back end"});
  ASSERT_TRUE(cache.store(module, result));
  ASSERT_TRUE(cache.store_alias(source, module, {{Severity::Warning, "S.hlsl", 3, "from the front end"}}));
  ASSERT_TRUE(cache.commit());
  bool rejected = true;
  std::optional<Hash128> target;
  auto loaded = load(cache, source, rejected, &target);
  ASSERT_TRUE(loaded);
  EXPECT_FALSE(rejected);
  EXPECT_EQ(target, module);
  EXPECT_EQ(loaded->blobs, result.blobs);
  ASSERT_EQ(loaded->messages.size(), 2u);
  EXPECT_EQ(loaded->messages[0].text, "from the front end");
  EXPECT_EQ(loaded->messages[0].line, 3);
  EXPECT_EQ(loaded->messages[1].text, "from the back end");
}

TEST(Cache, AliasWhoseTargetIsMissingCorruptOrAnAliasIsAMiss) {
  testing::TempDir dir;
  Hash128 source = hash128("source"), module = hash128("module"), chain = hash128("chain");
  bool rejected = true;
  {
    Cache cache(dir.path());
    ASSERT_TRUE(cache.store_alias(source, module, {}));
    ASSERT_TRUE(cache.commit());
    EXPECT_FALSE(load(cache, source, rejected));  // target missing: a plain miss
    EXPECT_FALSE(rejected);
  }
  std::filesystem::path target_segment;
  {
    Cache cache(dir.path());
    ASSERT_TRUE(cache.store(module, sample_output()));
    ASSERT_TRUE(cache.commit());
    ASSERT_TRUE(load(cache, source, rejected));
    for (const auto& file : cache.segment_files())  // the result's segment is the larger one
      if (target_segment.empty() || std::filesystem::file_size(file) > std::filesystem::file_size(target_segment))
        target_segment = file;
  }
  ASSERT_FALSE(target_segment.empty());
  std::string corrupt = testing::read_file(target_segment);
  corrupt[kSegmentHeader + kRecordHeader + 5] ^= 1;
  dir.write(target_segment.filename().string(), corrupt);
  {
    Cache cache(dir.path());
    EXPECT_FALSE(load(cache, source, rejected));
    EXPECT_TRUE(rejected);
  }
  // kiln never writes an alias to an alias; one found is rejected, not followed.
  Cache cache(dir.path());
  ASSERT_TRUE(cache.store_alias(chain, source, {}));
  ASSERT_TRUE(cache.store(module, sample_output()));
  ASSERT_TRUE(cache.commit());
  EXPECT_FALSE(load(cache, chain, rejected));
  EXPECT_TRUE(rejected);
  EXPECT_TRUE(load(cache, source, rejected));
}

TEST(Cache, FailuresAreNeverStoredAndAnEmptyCommitWritesNothing) {
  testing::TempDir dir;
  Cache cache(dir.path() / "c");
  JobOutput failed;
  failed.ok = false;
  EXPECT_FALSE(cache.store(hash128("k"), failed));
  EXPECT_TRUE(cache.commit());
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "c"));
}

TEST(Cache, TheSameEntriesMakeTheSameSegmentInAnyOrder) {
  testing::TempDir dir;
  Cache a(dir.path() / "a"), b(dir.path() / "b");
  for (int i = 0; i < 20; ++i) ASSERT_TRUE(a.store(hash128("k" + std::to_string(i)), sample_output(std::to_string(i))));
  for (int i = 19; i >= 0; --i) ASSERT_TRUE(b.store(hash128("k" + std::to_string(i)), sample_output(std::to_string(i))));
  ASSERT_TRUE(a.commit());
  ASSERT_TRUE(b.commit());
  std::filesystem::path sa = only_segment(a), sb = only_segment(b);
  EXPECT_EQ(sa.filename(), sb.filename());
  EXPECT_EQ(testing::read_file(sa), testing::read_file(sb));
}

TEST(Cache, SegmentsPastTheLimitAreMergedIntoTheNewOneAndTheLargestIsKept) {
  testing::TempDir dir;
  std::filesystem::path largest;
  {
    Cache cache(dir.path());
    for (int i = 0; i < 50; ++i) cache.store(hash128("base" + std::to_string(i)), sample_output(std::to_string(i)));
    ASSERT_TRUE(cache.commit());
    largest = only_segment(cache);
  }
  for (size_t build = 0; build < 2 * Cache::kMaxSegments; ++build) {
    Cache cache(dir.path());
    cache.store(hash128("edit" + std::to_string(build)), sample_output("edit"));
    ASSERT_TRUE(cache.commit());
    EXPECT_LE(cache.segment_files().size(), Cache::kMaxSegments);
  }
  Cache cache(dir.path());
  EXPECT_TRUE(std::filesystem::exists(largest)) << "the bulk of the cache is not rewritten by merges";
  EXPECT_EQ(cache.indexed_keys(), 50 + 2 * Cache::kMaxSegments);
  bool rejected = false;
  for (size_t build = 0; build < 2 * Cache::kMaxSegments; ++build)
    EXPECT_TRUE(load(cache, hash128("edit" + std::to_string(build)), rejected)) << build;
  EXPECT_TRUE(load(cache, hash128("base7"), rejected));
}

TEST(Cache, ABuildKeepsReadingTheSegmentsItOpenedWhenAnotherBuildMergesThemAway) {
  testing::TempDir dir;
  for (size_t build = 0; build < Cache::kMaxSegments; ++build) {
    Cache cache(dir.path());
    cache.store(hash128("k" + std::to_string(build)), sample_output(std::to_string(build)));
    ASSERT_TRUE(cache.commit());
  }
  Cache reader(dir.path());
  bool rejected = false;
  ASSERT_TRUE(load(reader, hash128("k0"), rejected));  // the reader has opened every segment
  {
    Cache writer(dir.path());
    writer.store(hash128("new"), sample_output("new"));
    ASSERT_TRUE(writer.commit());
    EXPECT_EQ(writer.segment_files().size(), 2u);  // the largest, and the merge of the rest with "new"
  }
  for (size_t build = 1; build < Cache::kMaxSegments; ++build)
    EXPECT_TRUE(load(reader, hash128("k" + std::to_string(build)), rejected)) << build;
}

TEST(Cache, PastItsSizeLimitTheLeastRecentlyUsedSegmentsGoFirst) {
  testing::TempDir dir;
  std::string big(20000, ' ');  // incompressible: segments of ~20 KB each (outputs are stored compressed)
  uint32_t state = 1;
  for (char& c : big) c = static_cast<char>('!' + (state = state * 1664525u + 1013904223u) % 90);
  std::vector<std::filesystem::path> segments;
  for (int i = 0; i < 3; ++i) {
    Cache cache(dir.path());
    cache.store(hash128("k" + std::to_string(i)), sample_output(big + std::to_string(i)));
    ASSERT_TRUE(cache.commit());
    for (const auto& file : cache.segment_files())
      if (std::find(segments.begin(), segments.end(), file) == segments.end()) segments.push_back(file);
    // Distinct ages, oldest first (the file system's clock may be coarse).
    std::filesystem::last_write_time(segments.back(), std::filesystem::file_time_type::clock::now() - std::chrono::hours(10 - i));
  }
  ASSERT_EQ(segments.size(), 3u);
  const uint64_t one = std::filesystem::file_size(segments[0]);
  // A build that reads k0 (the oldest segment) and writes k3, with room for three segments: k1's goes.
  Cache cache(dir.path(), 3 * one + one / 2);
  bool rejected = false;
  ASSERT_TRUE(load(cache, hash128("k0"), rejected));
  cache.store(hash128("k3"), sample_output(big + "3"));
  ASSERT_TRUE(cache.commit());
  EXPECT_TRUE(std::filesystem::exists(segments[0])) << "used by the build: now the most recently used";
  EXPECT_FALSE(std::filesystem::exists(segments[1]));
  EXPECT_TRUE(std::filesystem::exists(segments[2]));
  EXPECT_TRUE(load(cache, hash128("k3"), rejected));
  EXPECT_FALSE(load(cache, hash128("k1"), rejected));
  // A build that only reads (nothing to write) still keeps the limit, and never removes what it wrote.
  Cache tiny(dir.path(), 1);
  ASSERT_TRUE(load(tiny, hash128("k2"), rejected));
  ASSERT_TRUE(tiny.commit());
  EXPECT_TRUE(tiny.segment_files().empty());
  tiny.store(hash128("k4"), sample_output(big));
  ASSERT_TRUE(tiny.commit());
  EXPECT_EQ(tiny.segment_files().size(), 1u);
  EXPECT_TRUE(load(tiny, hash128("k4"), rejected));
}

TEST(Cache, AMemoKeyCanHoldSeveralMemosAndTheAcceptedOneIsReturned) {
  testing::TempDir dir;
  const Hash128 key = hash128("memo");
  for (uint64_t version : {1u, 2u}) {
    Cache cache(dir.path());
    cache.store_memo(key, PreprocessMemo{hash128("source v" + std::to_string(version)), {{"S.hlsl", version}, {"lib/F.hlsl", 7}}});
    ASSERT_TRUE(cache.commit());
  }
  Cache cache(dir.path());
  EXPECT_EQ(cache.segment_files().size(), 2u);
  for (uint64_t version : {1u, 2u}) {
    auto memo = cache.load_memo(key, [&](const PreprocessMemo& m) { return m.files[0].second == version; });
    EXPECT_EQ(cache.rejected_loads(), 0u);
    ASSERT_TRUE(memo) << version;
    EXPECT_EQ(memo->source_key, hash128("source v" + std::to_string(version)));
    ASSERT_EQ(memo->files.size(), 2u);
    EXPECT_EQ(memo->files[1], (std::pair<std::string, uint64_t>{"lib/F.hlsl", 7}));
  }
  bool rejected = false;
  EXPECT_FALSE(cache.load_memo(key, [](const PreprocessMemo&) { return false; }));
  EXPECT_EQ(cache.rejected_loads(), 0u);
  // A memo is not a compile result: its key loads nothing, and is not counted as a rejected entry.
  EXPECT_FALSE(load(cache, key, rejected));
  EXPECT_FALSE(rejected);
}

TEST(Cache, ACommitRemovesTemporarySegmentsAbandonedAnHourAgo) {
  testing::TempDir dir;
  dir.write("seg-0123.kseg.tmp.999.0", "half a segment from a build that was killed");
  dir.write("seg-4567.kseg.tmp.999.1", "a segment being written right now");
  dir.write("notes.txt.tmp.1.0", "not kiln's");
  for (const char* name : {"seg-0123.kseg.tmp.999.0", "notes.txt.tmp.1.0"})
    std::filesystem::last_write_time(dir.path() / name, std::filesystem::file_time_type::clock::now() - std::chrono::hours(2));
  Cache cache(dir.path());
  cache.store(hash128("k"), sample_output());
  ASSERT_TRUE(cache.commit());
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "seg-0123.kseg.tmp.999.0"));
  EXPECT_TRUE(std::filesystem::exists(dir.path() / "seg-4567.kseg.tmp.999.1"));
  EXPECT_TRUE(std::filesystem::exists(dir.path() / "notes.txt.tmp.1.0"));
}

}  // namespace
}  // namespace kiln
