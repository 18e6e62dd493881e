// SPDX-License-Identifier: Apache-2.0
// Writing outputs as kiln does (kiln/output_file.hpp), and the scratch directories and display paths its tools
// use. Part of the compiler's public API (kiln::compiler).
#pragma once

#include <unistd.h>

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "kiln/output_file.hpp"  // write_output_file: how every output is written
#include "kiln/result.hpp"

namespace kiln {

// A scratch directory `directory/<prefix><pid>-XXXXXX` of this process, made after removing every
// `<prefix><pid>-*` left there by a process that no longer runs (killed mid-way: its scratch would otherwise stay
// forever). Another live process's scratch is left alone. Empty when it cannot be made.
std::filesystem::path make_scratch_directory(const std::filesystem::path& directory, std::string_view prefix);

// A path as shown to users: relative to the working directory when below it.
std::string display_path(const std::filesystem::path& path);

// A file descriptor closed with its owner (an inotify, signalfd or eventfd of a long-running mode).
class Descriptor {
 public:
  explicit Descriptor(int fd = -1) : fd_(fd) {}
  Descriptor(const Descriptor&) = delete;
  Descriptor& operator=(const Descriptor&) = delete;
  ~Descriptor() {
    if (fd_ >= 0) ::close(fd_);
  }
  int get() const { return fd_; }

 private:
  int fd_;
};

}  // namespace kiln
