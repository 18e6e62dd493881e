// SPDX-License-Identifier: Apache-2.0
// What kiln's command line means, for tools that offer the same options (an editor, a build system's own front
// end): -D, the binding shifts, and --shard with the schedulers it reads. Part of the compiler's public API.
#pragma once

#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "kiln/diagnostics.hpp"
#include "kiln/folded_keywords.hpp"
#include "kiln/model.hpp"
#include "kiln/result.hpp"

namespace kiln {

// The command line's spellings (docs/bindings.md): "NAME[=VALUE]" for -D; "N SPACE" (SPACE a number or
// "all") for -fvk-<class>-shift; "N M" for -fvk-bind-globals. Errors are K1014, at "<command line>".
std::optional<std::vector<Define>> parse_command_line_defines(const std::vector<std::string>& texts, DiagnosticSink& sink);
// --keyword-kind "KEYWORD[,KEYWORD...]=KIND" (a pack's "keyword_kinds", docs/keywords.md): keyword -> kind.
std::optional<std::map<std::string, KeywordKind>> parse_command_line_keyword_kinds(const std::vector<std::string>& texts,
                                                                                 DiagnosticSink& sink);
bool parse_command_line_shift(RegisterClass register_class, const std::string& shift, const std::string& space,
                              BindingOptions& options, DiagnosticSink& sink);
bool parse_command_line_globals(const std::string& binding, const std::string& set, BindingOptions& options,
                                DiagnosticSink& sink);

// --shard I/N (0 <= I < N), or auto, read from the scheduler's variables through `environment` (getenv, or a
// test's): Slurm job arrays (SLURM_ARRAY_TASK_ID with SLURM_ARRAY_TASK_COUNT, or with SLURM_ARRAY_TASK_MIN/MAX),
// GitLab parallel jobs (CI_NODE_INDEX, 1-based, and CI_NODE_TOTAL), Kubernetes Indexed Jobs (JOB_COMPLETION_INDEX
// with KILN_SHARD_COUNT, which the job sets to its completions). The error says what was read and why it will not do.
struct Shard {
  unsigned index = 0;
  unsigned count = 1;
};
inline constexpr unsigned kMaxShardCount = 100000;
Result<Shard> parse_shard_option(const std::string& text, const std::function<const char*(const char*)>& environment);

}  // namespace kiln
