// SPDX-License-Identifier: Apache-2.0
// Reading user files with kiln's safety rules; writing outputs atomically is kiln/files.hpp (public).
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>
#include <string_view>

#include "kiln/diagnostics.hpp"
#include "kiln/files.hpp"
#include "kiln/result.hpp"

namespace kiln {

struct ReadLimits {
  // Shader sources and JSON above this are refused; the largest real shader library file is ~200 KiB.
  uint64_t max_file_bytes = 4u << 20;
};

// Reads a text file: regular files only (never blocks on a FIFO), size limit, no NUL bytes,
// valid UTF-8; a UTF-8 BOM is dropped. On failure reports to `sink` at `referenced_from`
// (the #include line or the command line) and returns nothing.
std::optional<std::string> read_text_file(const std::filesystem::path& path, const ReadLimits& limits,
                                          DiagnosticSink& sink, const SourceLocation& referenced_from);

// Reads any file whole; nothing on failure.
std::optional<std::string> read_binary_file(const std::filesystem::path& path);

// Where a JSON string value first appears in a JSON file's text (for diagnostics on JSON inputs).
SourceLocation locate_json_string(const std::string& path, std::string_view text, std::string_view value);

}  // namespace kiln
