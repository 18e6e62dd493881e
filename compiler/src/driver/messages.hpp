// SPDX-License-Identifier: Apache-2.0
// Where the build's compile messages point, and how they are reported: each distinct message once, naming the
// first variant it came from and how many more, in compile order (never in the order workers finished).
#pragma once

#include <cstddef>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include "driver/plan.hpp"
#include "frontend/frontend.hpp"
#include "kiln/diagnostics.hpp"

namespace kiln {

// Places front-end messages in the user's files (the build's snapshot of them, never read again).
class SourceLocator {
 public:
  explicit SourceLocator(const Plan& plan);

  // A message's location, with a column when glslang gave none but quoted the token, and a directive's errors
  // on the directive's own line. `fallback`: the path when the message names none.
  SourceLocation located(const FrontendMessage& message, const std::string& fallback) const;

  // Where a pass's sources first name `name` as a whole word outside comments: the declaration of a resource
  // a back-end step reports on (SPIR-V keeps no source lines); the entry file when not found.
  // `first`: a file searched before the pass's others (a stage's own entry file, for a stage's variable).
  SourceLocation declaration(uint32_t pass, const std::string& name, const std::string& entry_name,
                             const std::filesystem::path& first = {}) const;

  // Where a pass's sources first give `vk::constant_id(N)`, outside comments, with N one of `ids`: the location (at
  // the number) and N.
  std::optional<std::pair<SourceLocation, uint32_t>> constant_id(uint32_t pass, const std::set<uint32_t>& ids) const;

  // The text of a line of a file of the snapshot; empty when unknown.
  std::string line(const std::string& display_name, int line) const;

 private:
  const Plan& plan_;
  std::map<std::string, std::filesystem::path> by_name_;  // display name -> canonical path
};

// "pass 'Forward' fragment stage, keywords [_FOG]"
std::string variant_description(const Plan& plan, uint32_t pass, Stage stage, const std::vector<std::string>& keywords);

// The first name quoted in a message ("buffer block 'C' is ...").
std::string quoted_name(const std::string& message);

// Best-effort column for a glslang message that quotes a token; 0 when unknown (never a made-up one).
int guess_column(const std::string& line_text, const std::string& message);

class MessageGroups {
 public:
  // `order`: the compile index of the variant it came from (the sort key of the report). `notes`: printed after
  // the variants' (the first collection of a message gives them).
  void collect(DiagId id, SourceLocation at, const std::string& text, const std::string& variant, size_t order,
               std::vector<std::string> notes = {});
  bool has_errors() const;
  // Reports every group to `sink`, in order.
  void report(DiagnosticSink& sink);

 private:
  struct Group {
    DiagId id;
    SourceLocation at;
    std::string text;
    std::vector<std::pair<size_t, std::string>> variants;  // compile index, description
    std::vector<std::string> notes;
  };
  std::vector<Group> groups_;
  std::map<std::tuple<int, std::string, int, std::string>, size_t> index_;
};

}  // namespace kiln
