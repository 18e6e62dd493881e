// Writing outputs as kiln does (atomically, with errors that say which file and why), and the scratch directories
// and display paths its tools use. Part of the compiler's public API (kiln::compiler).
#pragma once

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "kiln/result.hpp"

namespace kiln {

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

}  // namespace kiln
