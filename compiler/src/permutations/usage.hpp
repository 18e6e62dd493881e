// SPDX-License-Identifier: Apache-2.0
// Usage logs (docs/usage.md) for `kiln build --usage`: reading one with the build's limits, and stripping to the
// keyword sets the runs asked for. The logs' types and the tools over them are public: kiln/recorded_usage.hpp.
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
#include "kiln/recorded_usage.hpp"
#include "permutations/permutations.hpp"

namespace kiln {

// The log in `file`, checked against variants/schema/usage.schema.json's rules; a mistake is K1015 at its place.
std::optional<UsageLog> load_usage_log(const std::filesystem::path& file, const ReadLimits& limits, DiagnosticSink& sink);

// Keeps the variants of `expansion` whose keyword set a log asked for (served or missing), and with `margin` > 0
// those that differ from one in at most `margin` keyword groups. One strip line per log (what it alone would keep),
// then one for all of them. A pass no log mentions is kept whole (and said so). False (K1305 reported at the first
// log) when nothing of a pass the logs mention is left.
bool strip_by_usage(const PassKeywords& pass, const std::string& pass_name, PassExpansion& expansion,
                    const std::vector<UsageLog>& logs, unsigned margin, std::vector<StripLine>& strip,
                    DiagnosticSink& sink);

}  // namespace kiln
