// Usage logs (docs/usage.md): what games asked a pack for, recorded by the readers (PackReader::record_usage), read
// back here for `kiln build --usage` (stripping to the keyword sets the runs asked for) and `kiln check-usage`.
#pragma once

#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "common/files.hpp"
#include "kiln/build.hpp"
#include "kiln/diagnostics.hpp"
#include "permutations/permutations.hpp"

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

// The log in `file`, checked against variants/schema/usage.schema.json's rules; a mistake is K1015 at its place.
std::optional<UsageLog> load_usage_log(const std::filesystem::path& file, const ReadLimits& limits, DiagnosticSink& sink);

// Where the log names its pack (for a log of another pack); the file's start when the field cannot be found.
SourceLocation usage_log_pack_location(const UsageLog& log);

// Whether the log carries every tag of `filters` (key, value).
bool usage_matches(const UsageLog& log, const std::vector<std::pair<std::string, std::string>>& filters);

// The logs in `files` that carry every tag of `filters`, in order. A malformed one is reported (K1015) and left out;
// `without_tags`, when given, counts the well-formed ones left out for their tags.
std::vector<UsageLog> load_usage_logs(const std::vector<std::string>& files,
                                      const std::vector<std::pair<std::string, std::string>>& filters,
                                      DiagnosticSink& sink, size_t* without_tags = nullptr);

// Keeps the variants of `expansion` whose keyword set a log asked for (served or missing), and with `margin` > 0
// those that differ from one in at most `margin` keyword groups. One strip line per log (what it alone would keep),
// then one for all of them. A pass no log mentions is kept whole (and said so). False (K1305 reported at the first
// log) when nothing of a pass the logs mention is left.
bool strip_by_usage(const PassKeywords& pass, const std::string& pass_name, PassExpansion& expansion,
                    const std::vector<UsageLog>& logs, unsigned margin, std::vector<StripLine>& strip,
                    DiagnosticSink& sink);

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
