// SPDX-License-Identifier: Apache-2.0
// The usage logs games record (docs/usage.md), as the compiler reads them: `kiln build --usage` strips by them
// (permutations/, which implements this header), `kiln check-usage` and `kiln merge-usage` read and merge them
// (kiln/pack_tools.hpp). Part of the compiler's public API (kiln::compiler). The log's text itself is written by
// kiln/usage_log.hpp, which the readers share.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "kiln/diagnostics.hpp"

namespace kiln {

struct UsageRequest {
  std::vector<std::string> keywords;  // sorted
  uint64_t count = 0;
  bool missing = false;               // the pack lacked it (the reader's Stripped)
  std::vector<std::string> nearest;   // when missing: the nearest variant the reader named
};

struct UsageLog {
  std::filesystem::path file;
  std::string text;  // as read (the inputs hash)
  std::string pack;
  std::map<std::string, std::string> tags;
  std::map<std::string, std::vector<UsageRequest>> passes;  // by pass name
  uint64_t missing_dropped = 0;
};

// Where the log names its pack (for a log of another pack); the file's start when the field cannot be found.
SourceLocation usage_log_pack_location(const UsageLog& log);

// Whether the log carries every tag of `filters` (key, value).
bool usage_matches(const UsageLog& log, const std::vector<std::pair<std::string, std::string>>& filters);

// The logs in `files` that carry every tag of `filters`, in order. A malformed one is reported (K1015) and left out;
// `without_tags`, when given, counts the well-formed ones left out for their tags.
std::vector<UsageLog> load_usage_logs(const std::vector<std::string>& files,
                                      const std::vector<std::pair<std::string, std::string>>& filters,
                                      DiagnosticSink& sink, size_t* without_tags = nullptr);

// `kiln merge-usage` (docs/usage.md, "Merging logs"): the logs as one log of the same format. Counts of the same
// keyword set are added (a served set and a missing set separately; a missing set keeps the first log's nearest
// variant); the tags are those every log has with the same value; with `passes` not empty, only those passes.
// Nothing (K1015 at the log) when the logs are of different packs.
struct UsageMerge {
  std::string text;  // the merged log
  size_t passes = 0, sets = 0;
  uint64_t selections = 0;
};
std::optional<UsageMerge> merge_usage_logs(const std::vector<UsageLog>& logs, const std::set<std::string>& passes,
                                           DiagnosticSink& sink);

}  // namespace kiln
