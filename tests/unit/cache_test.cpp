#include <gtest/gtest.h>

#include "cache/cache.hpp"
#include "test_support.hpp"

namespace kiln {
namespace {

JobOutput sample_output() {
  JobOutput out;
  out.ok = true;
  out.spirv = {0x07230203, 1, 2, 3};
  out.sources[Target::Glsl] = "#version 450\nvoid main() {}\n";
  out.reflection = {{"resources", nlohmann::json::array()}};
  return out;
}

TEST(Cache, StoredEntryLoadsBackIdentically) {
  testing::TempDir dir;
  Cache cache(dir.path());
  Hash128 key = hash128("key");
  ASSERT_TRUE(cache.store(key, sample_output()));
  bool rejected = true;
  auto loaded = cache.load(key, rejected);
  ASSERT_TRUE(loaded);
  EXPECT_FALSE(rejected);
  EXPECT_EQ(loaded->spirv, sample_output().spirv);
  EXPECT_EQ(loaded->sources.at(Target::Glsl), sample_output().sources.at(Target::Glsl));
}

TEST(Cache, CorruptTruncatedOrForeignEntriesAreMisses) {
  testing::TempDir dir;
  Cache cache(dir.path());
  Hash128 key = hash128("key"), other = hash128("other");
  ASSERT_TRUE(cache.store(key, sample_output()));
  std::string good = testing::read_file(cache.entry_path(key));
  bool rejected = false;

  std::string corrupt = good;
  corrupt[corrupt.size() - 5] ^= 1;
  dir.write(cache.entry_path(key).lexically_relative(dir.path()).string(), corrupt);
  EXPECT_FALSE(cache.load(key, rejected));
  EXPECT_TRUE(rejected);

  dir.write(cache.entry_path(key).lexically_relative(dir.path()).string(), good.substr(0, good.size() - 10));
  EXPECT_FALSE(cache.load(key, rejected));
  EXPECT_TRUE(rejected);

  // An entry copied under another key (a foreign entry) is detected by the key stored inside it.
  dir.write(cache.entry_path(other).lexically_relative(dir.path()).string(), good);
  EXPECT_FALSE(cache.load(other, rejected));
  EXPECT_TRUE(rejected);

  // Rewriting fixes it.
  ASSERT_TRUE(cache.store(key, sample_output()));
  EXPECT_TRUE(cache.load(key, rejected));
}

TEST(Cache, FailuresAreNeverStored) {
  testing::TempDir dir;
  Cache cache(dir.path());
  JobOutput failed;
  failed.ok = false;
  EXPECT_FALSE(cache.store(hash128("k"), failed));
  EXPECT_TRUE(testing::files_below(dir.path()).empty());
}

}  // namespace
}  // namespace kiln
