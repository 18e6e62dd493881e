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

TEST(Cache, AliasServesItsTargetWithItsOwnMessagesFirst) {
  testing::TempDir dir;
  Cache cache(dir.path());
  Hash128 source = hash128("source"), module = hash128("module");
  JobOutput result = sample_output();
  result.messages.push_back({Severity::Warning, "", 0, "from the back end"});
  ASSERT_TRUE(cache.store(module, result));
  ASSERT_TRUE(cache.store_alias(source, module, {{Severity::Warning, "S.hlsl", 3, "from the front end"}}));
  bool rejected = true;
  auto loaded = cache.load(source, rejected);
  ASSERT_TRUE(loaded);
  EXPECT_FALSE(rejected);
  EXPECT_EQ(loaded->spirv, result.spirv);
  ASSERT_EQ(loaded->messages.size(), 2u);
  EXPECT_EQ(loaded->messages[0].text, "from the front end");
  EXPECT_EQ(loaded->messages[0].line, 3);
  EXPECT_EQ(loaded->messages[1].text, "from the back end");
}

TEST(Cache, AliasWhoseTargetIsMissingCorruptOrAnAliasIsAMiss) {
  testing::TempDir dir;
  Cache cache(dir.path());
  Hash128 source = hash128("source"), module = hash128("module"), chain = hash128("chain");
  ASSERT_TRUE(cache.store_alias(source, module, {}));
  bool rejected = true;
  EXPECT_FALSE(cache.load(source, rejected));  // target missing: a plain miss
  EXPECT_FALSE(rejected);

  ASSERT_TRUE(cache.store(module, sample_output()));
  std::string good = testing::read_file(cache.entry_path(module));
  std::string corrupt = good;
  corrupt[corrupt.size() - 5] ^= 1;
  dir.write(cache.entry_path(module).lexically_relative(dir.path()).string(), corrupt);
  EXPECT_FALSE(cache.load(source, rejected));
  EXPECT_TRUE(rejected);

  // kiln never writes an alias to an alias; one found is rejected, not followed.
  ASSERT_TRUE(cache.store_alias(chain, source, {}));
  ASSERT_TRUE(cache.store(module, sample_output()));
  EXPECT_FALSE(cache.load(chain, rejected));
  EXPECT_TRUE(rejected);
  EXPECT_TRUE(cache.load(source, rejected));
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
