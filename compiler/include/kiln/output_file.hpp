// SPDX-License-Identifier: Apache-2.0
// The one way kiln writes a file it was told to write (a -o path, a depfile, a summary, a pack, a cache entry, a
// usage log, an image): what is at the path decides how, so that nothing kiln did not make is ever replaced.
//
//   nothing there, or a regular file   a temporary file beside it (O_EXCL, never through a link) and rename(2):
//                                      readers see the old file or the new one, never a torn one
//   a character device or a FIFO       written in place, as glslc and DXC do (`-o /dev/null` checks a shader;
//                                      /dev/full is an error, ENOSPC; a FIFO waits for its reader)
//   a link to one of this process's    written through that descriptor, whatever it is, so that its offset moves
//   descriptors                        as the shell's does (`-o /dev/stdout > log`, `-o /dev/fd/3`, `-o >(xxd)`)
//   a link to a device or a FIFO       written in place through the link
//   a link to anything else            refused: kiln neither writes through it nor replaces it
//   a directory, block device, socket  refused
//
// Part of the reader library (a game writes its usage log with it) and so of the compiler's public API.
#pragma once

#include <filesystem>
#include <string_view>
#include <vector>

#include "kiln/result.hpp"

namespace kiln {

// The error says which file, what is there and why it cannot be written.
Result<void> write_output_file(const std::filesystem::path& path, std::string_view bytes);
// The same for a file made of several parts, written one after the other (no concatenated copy).
Result<void> write_output_file(const std::filesystem::path& path, const std::vector<std::string_view>& parts);

}  // namespace kiln
