// SPDX-License-Identifier: Apache-2.0
// What `kiln build` says after a build: the summary for people (the funnel, what was compiled and found cached, the
// remote cache's counts, the strip report, the stage times) and the same as JSON for CI dashboards
// (`--summary-json`; README.md lists its fields, which are only ever added). Part of the compiler's public API.
#pragma once

#include <string>

#include "kiln/build.hpp"
#include "kiln/diagnostics.hpp"

namespace kiln {

// Lines ending in a newline; a shard's build (--shard) says what it compiled and left to the other shards.
std::string build_summary_text(const BuildReport& report, const BuildOptions& options);
// The JSON document (indented, ending in a newline), written whether the build succeeded or not; `exit_code` is the
// run's (kiln::exit_code).
std::string build_summary_json(const BuildReport& report, const DiagnosticSink& sink, int exit_code, const BuildOptions& options);

}  // namespace kiln
