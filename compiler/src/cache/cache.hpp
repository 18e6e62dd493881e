// Content-addressed cache of compile results. The key covers kiln's version, the exact tool versions,
// every option, the stage, the entry point and the preprocessed text, so an include edit misses
// exactly the variants that read it. Two kinds of entry: a back end's result, keyed by the front end's
// SPIR-V module (plus the same versions and options), and for each stage source an alias naming its
// module's entry and carrying the front end's warnings; so an edit that changes no code the entry point
// reaches costs a front end, not a back end. Entries are checksummed; a corrupt, truncated or foreign
// entry (or an alias whose target is any of those) is a miss and is rewritten. Writes are atomic
// (temp + rename), so concurrent builds sharing a cache never see torn entries; both writers write the
// same bytes.
#pragma once

#include <atomic>
#include <filesystem>
#include <optional>

#include "common/hash.hpp"
#include "workers/compile_job.hpp"

namespace kiln {

class Cache {
 public:
  explicit Cache(std::filesystem::path directory);
  const std::filesystem::path& directory() const { return directory_; }

  // Nothing on a miss; `rejected` is set when an entry existed but failed its checks. An alias is
  // followed: the result is its target's, with the alias's messages first, and `target` (if given) is
  // set to the target's key.
  std::optional<JobOutput> load(const Hash128& key, bool& rejected, std::optional<Hash128>* target = nullptr) const;
  // Only successful results are ever stored: a failure (or a crash) is never cached.
  bool store(const Hash128& key, const JobOutput& output) const;
  bool store_alias(const Hash128& key, const Hash128& target, const std::vector<FrontendMessage>& messages) const;
  std::filesystem::path entry_path(const Hash128& key) const;

 private:
  struct Entry {
    std::optional<Hash128> alias;
    JobOutput output;  // an alias's: only its messages
  };
  std::optional<Entry> read(const Hash128& key, bool& rejected) const;
  bool write(const Hash128& key, uint32_t kind, std::string_view prefix, const JobOutput& output) const;

  std::filesystem::path directory_;
};

}  // namespace kiln
