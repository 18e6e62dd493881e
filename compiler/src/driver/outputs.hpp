// SPDX-License-Identifier: Apache-2.0
// The build's files besides the pack: the output directory, the stamp that makes a no-change build a no-op,
// and the depfile a build tool reads.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "kiln/build.hpp"
#include "kiln/diagnostics.hpp"
#include "kiln/result.hpp"

namespace kiln {

// Creates the output directory; false (reported) when it cannot be written, before any work is spent.
[[nodiscard]] bool prepare_output_directory(const std::filesystem::path& directory, DiagnosticSink& sink);

// The pack's archive file name when the pack in `directory` is the one the stamp was written with, for these
// inputs; nothing when it must be built.
std::optional<std::string> current_archive(const std::filesystem::path& directory, const std::string& name,
                                           const std::string& inputs_hash);

// The stamp (<name>.stamp) records the inputs hash, the size and mtime of the manifest, and the name, size and
// mtime of the archive it was written with: a no-change rebuild compares a few numbers instead of re-reading a
// large pack. The error says what went wrong.
Result<void> write_stamp(const std::filesystem::path& directory, const std::string& name,
                                      const std::string& archive_file, const std::string& inputs_hash);

}  // namespace kiln
