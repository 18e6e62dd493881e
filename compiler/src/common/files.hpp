// Reading user files with kiln's safety rules, and writing outputs atomically.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>
#include <string_view>

#include "kiln/diagnostics.hpp"
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

// Writes via a temporary file in the same directory and rename(2): readers see the old file or the
// new one, never a torn one. The error says which file could not be made, written or renamed, and why.
Result<void> write_file_atomic(const std::filesystem::path& path, std::string_view bytes);
// The same for a file made of several parts, written one after the other (no concatenated copy).
Result<void> write_file_atomic(const std::filesystem::path& path, const std::vector<std::string_view>& parts);

// A scratch directory `directory/<prefix><pid>-XXXXXX` of this process, made after removing every
// `<prefix><pid>-*` left there by a process that no longer runs (killed mid-way: its scratch would otherwise stay
// forever). Another live process's scratch is left alone. Empty when it cannot be made.
std::filesystem::path make_scratch_directory(const std::filesystem::path& directory, std::string_view prefix);

// A path as shown to users: relative to the working directory when below it.
std::string display_path(const std::filesystem::path& path);


// Where a JSON string value first appears in a JSON file's text (for diagnostics on JSON inputs).
SourceLocation locate_json_string(const std::string& path, std::string_view text, std::string_view value);

}  // namespace kiln
