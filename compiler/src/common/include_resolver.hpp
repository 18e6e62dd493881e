// SPDX-License-Identifier: Apache-2.0
// Include resolution confined to declared roots: no escape through "..", absolute paths or symlinks.
// Shared by the declaration scanner (stage 1) and the glslang includer (stage 4).
#pragma once

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "kiln/result.hpp"
#include "common/files.hpp"
#include "kiln/diagnostics.hpp"

namespace kiln {

class IncludeRoots {
 public:
  explicit IncludeRoots(const std::vector<std::filesystem::path>& roots);
  const std::vector<std::filesystem::path>& roots() const { return roots_; }
  bool contains(const std::filesystem::path& canonical) const;

 private:
  std::vector<std::filesystem::path> roots_;  // canonical
};

struct ResolvedInclude {
  std::filesystem::path path;  // canonical
  // Where a new file would take this one's place: for each candidate searched before the match, the directory that
  // would hold it (or, if that does not exist yet, its nearest existing ancestor inside the roots). A build tool
  // that watches them (the depfile lists them) notices a new header that shadows an include.
  std::vector<std::filesystem::path> watch;
};

// Resolves `name` as written in `#include "name"` inside `including_file` (canonical): first next to
// the including file, then in each root, in order. The error is the diagnostic to report at the #include (its
// id, message and notes; the caller knows the location).
Result<ResolvedInclude, Diagnostic> resolve_include(std::string_view name, const std::filesystem::path& including_file,
                                                    const IncludeRoots& roots);


}  // namespace kiln
