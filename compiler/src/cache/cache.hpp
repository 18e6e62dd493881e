// Content-addressed cache of compile results. The key covers kiln's version, the exact tool versions,
// every option, the stage, the entry point and the preprocessed text, so an include edit misses
// exactly the variants that read it. Entries are checksummed; a corrupt, truncated or foreign entry
// is a miss and is rewritten. Writes are atomic (temp + rename), so concurrent builds sharing a
// cache never see torn entries; both writers write the same bytes.
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

  // Nothing on a miss; `rejected` is set when an entry existed but failed its checks.
  std::optional<JobOutput> load(const Hash128& key, bool& rejected) const;
  // Only successful results are ever stored: a failure (or a crash) is never cached.
  bool store(const Hash128& key, const JobOutput& output) const;
  std::filesystem::path entry_path(const Hash128& key) const;

 private:
  std::filesystem::path directory_;
};

}  // namespace kiln
