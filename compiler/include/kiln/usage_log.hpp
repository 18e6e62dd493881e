// SPDX-License-Identifier: Apache-2.0
// The usage log's text (docs/usage.md, variants/schema/usage.schema.json), one writer for the readers' recording
// (PackReader::flush_usage) and for `kiln merge-usage`, so that both write the same bytes for the same counts.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "kiln/result.hpp"

namespace kiln::usage_log {

struct Request {
  std::vector<std::string> keywords;
  uint64_t count = 0;
  std::vector<std::string> nearest;  // missing requests only
};

struct Pass {
  std::string name;
  std::vector<Request> served, missing;
};

// The log: keyword lists sorted, each list of requests sorted by its keywords, passes in the order given; so equal
// counts give equal files.
std::string text(std::string_view pack, const std::map<std::string, std::string>& tags, std::vector<Pass> passes,
                 uint64_t missing_dropped);

// `text` into `file`, atomically (a temporary file beside it, renamed over it); the error says what failed.
Result<void> write_atomically(const std::filesystem::path& file, const std::string& text);

}  // namespace kiln::usage_log
